"""Documented imports of gbpipe.simulate give the documented objects in a fresh
interpreter, whatever was imported before (issue 11, item 5)."""

from __future__ import annotations

import subprocess
import sys

import pytest

CASES = [
    "from gbpipe.simulate import test, sweep; assert callable(test) and callable(sweep)",
    "import gbpipe.simulate as s; assert s.test.__module__ == 'gbpipe.simulate.campaign'",
    "import gbpipe.lti; from gbpipe.simulate import sweep; assert sweep.__name__ == 'sweep'",
    "from gbpipe.lti import lsim; import gbpipe.simulate as s; "
    "assert callable(lsim) and not hasattr(s, 'lsim')",
    "import importlib.util as u; assert u.find_spec('gbpipe.simulate.lsim') is None",
]


@pytest.mark.parametrize("code", CASES)
def test_documented_import(code):
    subprocess.run([sys.executable, "-c", code], check=True)
