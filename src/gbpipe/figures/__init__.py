"""Figures of the paper (3–17) and of the extensions, drawn from stage outputs.

Each ``fig*`` function takes datasets (or a config) and a path stem, and writes
``<stem>.png`` and ``<stem>.pdf``. Matplotlib runs headless (Agg).
"""
