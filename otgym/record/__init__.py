"""Recording sessions as MCAP files and reading them back (``mcap_file``)."""
