"""Which assumed parameters of the simulated participants decide Fig. 8 (``otgym experiment human-sensitivity``): ``run`` (the design, the trials and the analysis), ``report`` (the files)."""
