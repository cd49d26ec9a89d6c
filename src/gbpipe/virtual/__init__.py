"""Virtual torque sensors: the torque of any shaft or mount of a chain estimated from the
motor torques and the chosen sensors, with its 95 % band (docs/virtual.md).

Public API
----------
estimation_model(chain, measured, targets, loads, dt)
    The chain's discrete model with unknown loads and the offsets the data can tell apart.
fit_noise(model, y, u)
    Noise levels from the record (maximum likelihood on the innovations).
smooth(model, noise, y, u)
    Steady-state Kalman filter + RTS smoother: estimates (block by block, or whole) and
    their standard deviations.
virtual_record(settings, model_cfg, record, name, out), table_rows(ds, record)
    The ``virtual`` stage of one bench record (its output written block by block), and
    its rows of ``tables/virtual.csv``.
"""

from gbpipe.virtual.model import EstimationModel, estimation_model, target_names
from gbpipe.virtual.noise import NoiseFit, fit_noise, neg2_loglik
from gbpipe.virtual.smoother import BLOCK, Z95, Estimate, Gains, NoiseModel, gains, smooth
from gbpipe.virtual.stage import TABLE_COLUMNS, table_rows, virtual_record

__all__ = ["EstimationModel", "estimation_model", "target_names", "NoiseFit", "fit_noise",
           "neg2_loglik", "NoiseModel", "Gains", "Estimate", "gains", "smooth", "BLOCK", "Z95",
           "virtual_record", "table_rows", "TABLE_COLUMNS"]
