"""What every study shares: the seed protocol (``seeds``), the output folder check, progress lines, and the paper's published numbers (``paper_tables``)."""
