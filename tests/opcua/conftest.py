# SPDX-License-Identifier: MIT
"""pytest set-up for tests/opcua: the gateway suite's own (tests/gateway/
conftest.py: a time limit per test, processes that never outlive the run,
sanitizer reports, the "passed failed label" results line), loaded under
another name, and its helpers (gwlib) on the path."""
import importlib.util
import sys
from pathlib import Path

GATEWAY = Path(__file__).resolve().parents[1] / "gateway"
sys.path.insert(0, str(GATEWAY))

_spec = importlib.util.spec_from_file_location("gateway_conftest", GATEWAY / "conftest.py")
_gw = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_gw)
globals().update({k: v for k, v in vars(_gw).items() if not k.startswith("__")})
