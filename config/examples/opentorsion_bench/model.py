"""The back-to-back test bench as an openTorsion model.

Drive motor - jaw coupling - flywheel on a steel shaft - jaw coupling - torque
transducer - steel input shaft - a spur gear pair (1:2.5, speed reducing) - steel output
shaft - jaw coupling - load motor. Both motors turn freely on their bearings (dampers to
ground); their speed and torque controllers are not part of the mechanics.

Numbers: 30 kW / 1500 rpm induction motors (rotor 0.35 and 0.6 kg·m²), catalogue jaw
couplings (spider 24-40 kN·m/rad dynamic), a steel flywheel disk 0.5 m x 50 mm
(J = m·r²/2 = 2.4 kg·m²), a flange torque transducer of 1.1e5 N·m/rad, gear inertias
from the wheels' size; bearing and windage losses of the motors 0.04-0.06 N·m·s/rad.
Run it to print the damped natural frequencies [Hz].
"""

import numpy as np
import opentorsion as ot
from parts import jaw_coupling, machine, steel_shaft


def test_bench():
    """The bench: 9 nodes (0 drive motor ... 8 load motor), one gear stage."""
    disks = [
        machine(0, 0.35, drag=0.04),     # drive motor
        ot.Disk(1, 0.012),               # coupling hub
        ot.Disk(2, 2.4),                 # flywheel
        ot.Disk(3, 0.015),               # coupling hub / transducer flange
        ot.Disk(4, 0.010),               # transducer flange
        ot.Disk(7, 0.020),               # coupling hub
        machine(8, 0.60, drag=0.06),     # load motor
    ]
    pinion = ot.Gear(5, 0.008, 40.0)                 # 24 teeth, module 3.33: R in mm
    wheel = ot.Gear(6, 0.110, 100.0, parent=pinion)  # 60 teeth
    shafts = [
        jaw_coupling(0, 1, k_spider=2.4e4, j_spider=0.004, c=1.5),
        steel_shaft(1, 2, length=350.0, od=45.0, c=0.5),
        jaw_coupling(2, 3, k_spider=3.2e4, j_spider=0.004, c=1.5),
        ot.Shaft(3, 4, None, None, k=1.1e5, c=0.3),  # torque transducer
        steel_shaft(4, 5, length=250.0, od=40.0, c=0.4),
        steel_shaft(6, 7, length=300.0, od=55.0, c=0.6),
        jaw_coupling(7, 8, k_spider=4.0e4, j_spider=0.006, c=2.0),
    ]
    return ot.Assembly(shafts, disk_elements=disks, gear_elements=[pinion, wheel])


if __name__ == "__main__":
    wn, wd, zeta = test_bench().modal_analysis()
    print(np.round(np.asarray(wd)[np.asarray(wd) > 0] / (2 * np.pi), 2))
