"""The packages import in any order: no module of spfem_core or workflows is part of an import
cycle, whichever module a program imports first (a cycle shows only for some first imports)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

EACH_FIRST = """
import importlib, sys
from pathlib import Path

names = sorted(".".join(p.with_suffix("").parts).removesuffix(".__init__")
               for package in ("spfem_core", "workflows") for p in Path(package).rglob("*.py"))
failed = []
for name in names:
    for loaded in [key for key in sys.modules if key.split(".")[0] in ("spfem_core", "workflows")]:
        del sys.modules[loaded]
    try:
        importlib.import_module(name)
    except ImportError as error:
        failed.append(f"{name}: {error}")
print(len(names))
print("\\n".join(failed))
"""


def test_every_module_imports_as_the_first_one():
    done = subprocess.run([sys.executable, "-c", EACH_FIRST], cwd=REPO, capture_output=True, text=True, check=True)
    count, *failed = done.stdout.strip().splitlines()
    assert int(count) > 50 and failed == [], failed
