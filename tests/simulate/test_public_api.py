"""Documented imports of gbpipe.simulate give the documented objects in a fresh
interpreter, whatever was imported before (issue 11, item 5): every name the package
docstring lists is exported, is the object its module defines (not a stale copy or a
shadowing submodule), and nothing else is exported."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

import gbpipe.simulate

#: The names of the docstring's "Public API" section (each unindented entry line up to the
#: section's first blank line, without the arguments).
_SECTION = gbpipe.simulate.__doc__.split("Public API\n----------\n", 1)[1].split("\n\n")[0]
DOCUMENTED = sorted({
    name for line in _SECTION.splitlines() if re.match(r"^[A-Za-z_]", line)
    for name in re.findall(r"(?:^|,\s*)([A-Za-z_]\w*)", re.sub(r"\([^)]*\)", "", line))})

# (import done first, then the check), each in a fresh interpreter
CASES = [
    "import gbpipe.lti; import gbpipe.simulate as s; from gbpipe.simulate import campaign, "
    "designed, excitation; "
    "assert s.test is campaign.test and s.sweep is campaign.sweep; "
    "assert s.random_only is campaign.random_only and s.SIGNALS is campaign.SIGNALS; "
    "assert s.test_names is designed.test_names and s.multisine is excitation.multisine",
    # a test module named `test` must not shadow the function
    "import gbpipe.simulate.campaign; from gbpipe.simulate import test; "
    "assert test is gbpipe.simulate.campaign.test and test.__code__.co_varnames[:3] == "
    "('cfg', 'test', 'profile')",
    # the simulator is gbpipe.lti's, and only there
    "from gbpipe.lti import lsim; from gbpipe.lti import simulation; "
    "import gbpipe.simulate as s; assert lsim is simulation.lsim and not hasattr(s, 'lsim')",
    "import importlib.util as u; assert u.find_spec('gbpipe.simulate.lsim') is None",
]


def test_docstring_lists_exactly_the_exports():
    assert "test" in DOCUMENTED and "within_limits" in DOCUMENTED
    assert DOCUMENTED == sorted(gbpipe.simulate.__all__)


@pytest.mark.parametrize("code", CASES)
def test_documented_import(code):
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
