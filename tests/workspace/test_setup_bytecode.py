"""``scripts/setup.sh`` byte-compiles the packages in ``src/`` (each node process imports them at
start-up; where ``PYTHONDONTWRITEBYTECODE`` is set nothing else would write their ``.pyc``
files), and the compiled files are what the interpreter loads."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

from support.paths import PACKAGES, REPO


def test_every_package_module_has_its_bytecode() -> None:
    sources = [path for package in PACKAGES
               for path in (REPO / 'src' / package / package).rglob('*.py')]
    assert len(sources) > 100
    missing = [str(path.relative_to(REPO)) for path in sources
               if not Path(importlib.util.cache_from_source(str(path))).is_file()]
    assert missing == [], f'not byte-compiled (run ./pd setup): {missing[:5]}'


def test_the_compiled_module_is_the_one_loaded() -> None:
    code = ('import pd_core.run.loop.session as m, importlib.util, pathlib\n'
            'print(m.__spec__.cached)\n'
            'print(pathlib.Path(importlib.util.cache_from_source(m.__file__)).resolve())\n')
    cached, expected = subprocess.run([sys.executable, '-c', code], capture_output=True,
                                      text=True, check=True).stdout.split()
    assert Path(cached).resolve() == Path(expected)
    assert Path(expected).is_relative_to(REPO / 'src')
    assert Path(expected).is_file()
