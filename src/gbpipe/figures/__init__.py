"""Figures of the paper (3–17) and of the extensions, drawn from stage outputs.

Each ``fig*`` function takes datasets (or a config) and a path stem, and writes
``<stem>.png`` and ``<stem>.pdf``, or the formats of an enclosing
:func:`gbpipe.figures.style.formats` block (config ``figures.formats``). Matplotlib runs
headless (Agg).
"""
