"""gbpipe: data-driven dynamic models of wind-turbine gearboxes.

Torsional models of multi-stage gearboxes and back-to-back test benches, simulated test
campaigns, harmonic removal on real and virtual tachometers, and subspace identification.
``import gbpipe`` imports nothing else: each stage imports the sub-packages it uses
(``from gbpipe import io``, ``from gbpipe.harmonics import …``), so a job pays only for
what it touches. The package map and its layer contract: ``docs/architecture.md``.
"""

__version__ = "0.2.0"
