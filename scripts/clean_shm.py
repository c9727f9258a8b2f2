"""Remove Fast DDS shared-memory files in /dev/shm that no live process has open or mapped.

A process killed with SIGKILL (as a graph test does to a specimen node) leaves its segments
behind, and a test process keeps the segments of its peers mapped until it exits, so
``./pd test`` runs this after pytest. Files still in use are never touched.
"""

from __future__ import annotations

import os
from pathlib import Path

SHM = Path('/dev/shm')


def in_use() -> set[str]:
    """Names of /dev/shm files some live process has mapped or open."""
    used: set[str] = set()
    for proc in Path('/proc').iterdir():
        if not proc.name.isdigit():
            continue
        try:
            maps = (proc / 'maps').read_text(encoding='utf-8', errors='replace')
            used.update(line.rsplit('/', 1)[-1].split(' ')[0]
                        for line in maps.splitlines() if '/dev/shm/' in line)
            for fd in (proc / 'fd').iterdir():
                target = os.readlink(fd)
                if target.startswith('/dev/shm/'):
                    used.add(target.rsplit('/', 1)[-1])
        except OSError:
            continue
    return used


def main() -> int:
    """Remove the unused segments; print how many."""
    if not SHM.is_dir():
        return 0
    used = in_use()
    removed = 0
    for path in [*SHM.glob('fastdds_*'), *SHM.glob('sem.fastdds_*')]:
        if path.name not in used:
            try:
                path.unlink()
                removed += 1
            except OSError:
                pass
    if removed:
        print(f'clean_shm: removed {removed} unused Fast DDS shared-memory file(s)')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
