"""The obstacle scenarios' calibration (``otgym experiment calibrate-scenarios``): ``config`` (what it sweeps, light to import), ``run`` (the sweep and its files)."""
