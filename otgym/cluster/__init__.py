"""Sweeps: one otgym command run over a grid of options, one cell per combination.

``sweep_file`` reads and checks the sweep file (TOML) against the command's options;
``cell`` runs one cell, in-process, through the command's Python entry point and
collects the files it wrote; ``output`` puts a finished cell's files in place
atomically and keeps ``cells.csv``; ``engine`` runs the cells serially or as Ray tasks
(Ray Core: ``ray.remote`` tasks, ``max_retries`` for a lost node, ``ray.wait`` for
progress); ``summary`` puts the cells' results side by side where the command has a
table or a curve.

This package imports no other otgym package: the command's entry point and the
description of its options are handed in by ``otgym.cli.sweep``.
"""
