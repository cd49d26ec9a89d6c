"""Bench parts as openTorsion elements: the helpers the bench model imports.

Units as openTorsion takes them: lengths in mm, inertia in kg·m², stiffness in N·m/rad,
damping in N·m·s/rad.
"""

import opentorsion as ot

#: Shear modulus [Pa] and density [kg/m³] of the steel shafts.
G_STEEL, RHO_STEEL = 80.0e9, 7850.0


def steel_shaft(nl, nr, length, od, idl=0.0, c=0.0):
    """A steel shaft from its geometry [mm]: stiffness G·J_p/L, its own inertia spread
    along it (openTorsion's consistent mass)."""
    return ot.Shaft(nl, nr, L=length, odl=od, idl=idl, G=G_STEEL, rho=RHO_STEEL, c=c)


def jaw_coupling(nl, nr, k_spider, j_spider, c):
    """A jaw coupling: two elastomer spider halves in series, the spider's inertia along
    the coupling."""
    return ot.Shaft(nl, nr, None, None, k=1.0 / (2.0 / k_spider), I=j_spider, c=c)


def machine(node, inertia, drag):
    """A rotor on its bearings: the inertia, and the bearings' and windage losses as a
    damper to ground (no spring: the rotor turns freely)."""
    return ot.Disk(node, inertia, c=drag)
