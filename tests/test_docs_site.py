"""The documentation site (``mkdocs.yml``, ``docs/``) builds with warnings as errors, says only
what exists, and the README stays a front page.

``mkdocs build --strict`` fails on any warning: a page missing from the nav, a broken link or
anchor, an unresolved cross-reference, an API page naming an object that no longer exists; a
test shows that the configuration catches the first kinds. The repository paths and Python
names the pages cite are checked against ``src/`` (read as text: nothing is imported)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from pd_common.cli import help_text
from pd_core.run.runner import run_offline
from pd_core.run.test_file import load_test_file
from support.paths import DEFAULT_TEST, REPO

README_MAX_LINES = 250
# A repository path as the pages write it: `src/pd_integrator/config/default_test.yaml`.
REPOSITORY_PATH = re.compile(r'(?<![\w/.-])((?:src|tests|bench|scripts|docs)/[\w./-]*\w)')
# A Python name of one of our packages as the pages write it: `pd_common.experimental.limits`.
PACKAGES = sorted(path.name for path in (REPO / 'src').iterdir() if (path / path.name).is_dir())
PYTHON_NAME = re.compile(rf'(?<![\w./-])((?:{"|".join(PACKAGES)})(?:\.\w+)+)')


def _build(root: Path, site: Path) -> subprocess.CompletedProcess[str]:
    """``mkdocs build --strict`` of ``root/mkdocs.yml`` (run in ``root``, as ``./pd docs``)."""
    env = {**os.environ, 'NO_MKDOCS_2_WARNING': '1'}
    return subprocess.run([sys.executable, '-m', 'mkdocs', 'build', '--strict', '--config-file',
                           str(root / 'mkdocs.yml'), '--site-dir', str(site)],
                          cwd=root, env=env, capture_output=True, text=True, timeout=120,
                          check=False)


def _pages() -> list[Path]:
    return [*sorted((REPO / 'docs').rglob('*.md')), REPO / 'README.md', REPO / 'CONTRIBUTING.md']


def _defines(module: Path, name: str) -> bool:
    """Whether ``module`` defines, assigns or imports ``name`` (read as text, not imported)."""
    pattern = (rf'^\s*(?:def|class)\s+{name}\b|^\s*{name}\s*[:=]|^from .* import .*\b{name}\b'
               rf'|^\s+{name},?\s*$')
    return re.search(pattern, module.read_text(), re.MULTILINE) is not None


def _exists(dotted: str) -> bool:
    """Whether ``pkg.module[.name]`` is a module of ``src/`` or a name one of them defines."""
    parts = dotted.split('.')
    source = REPO / 'src' / parts[0]
    for end in range(len(parts), 0, -1):
        path = source.joinpath(*parts[:end])
        module = path / '__init__.py' if path.is_dir() else path.with_suffix('.py')
        if module.is_file():
            return end == len(parts) or _defines(module, parts[end])
    return False


def test_the_site_builds_with_warnings_as_errors(tmp_path: Path) -> None:
    site = tmp_path / 'site'
    done = _build(REPO, site)
    output = done.stdout + done.stderr
    assert done.returncode == 0, output
    assert 'WARNING' not in output, output
    # The generated parts are there: the API from the docstrings, ./pd help from the script,
    # CONTRIBUTING.md included whole.
    schemes = (site / 'reference' / 'api' / 'schemes' / 'index.html').read_text()
    assert 'NewmarkExplicit' in schemes
    cli = (site / 'reference' / 'cli' / 'index.html').read_text()
    assert './pd run' in cli and './pd test' in cli and '&lt;!-- pd help --&gt;' not in cli
    contributing = (site / 'contributing' / 'index.html').read_text()
    assert 'Import contracts' in contributing


def test_a_broken_link_or_reference_fails_the_build(tmp_path: Path) -> None:
    # A copy of the site's sources, the configuration unchanged, one page broken.
    shutil.copytree(REPO / 'docs', tmp_path / 'docs',
                    ignore=shutil.ignore_patterns('__pycache__'))
    shutil.copy(REPO / 'mkdocs.yml', tmp_path / 'mkdocs.yml')
    for name in ('src', 'pd', 'CONTRIBUTING.md'):
        (tmp_path / name).symlink_to(REPO / name)
    with (tmp_path / 'docs' / 'index.md').open('a') as page:
        page.write('\n[a page that is not there](tutorials/no-such-page.md)\n\n'
                   '[an object that is not there][pd_common.protocol.NoSuchThing]\n')
    done = _build(tmp_path, tmp_path / 'site')
    output = done.stdout + done.stderr
    assert done.returncode != 0, output
    assert 'no-such-page.md' in output, output
    assert 'pd_common.protocol.NoSuchThing' in output, output


def test_the_readme_is_a_front_page() -> None:
    lines = (REPO / 'README.md').read_text().splitlines()
    assert len(lines) <= README_MAX_LINES, f'README.md has {len(lines)} lines'


def test_every_repository_path_a_page_names_exists() -> None:
    named = {(page.relative_to(REPO).as_posix(), match.group(1))
             for page in _pages() for match in REPOSITORY_PATH.finditer(page.read_text())}
    assert len(named) > 50
    missing = sorted((page, path) for page, path in named if not (REPO / path).exists())
    assert missing == [], f'pages name paths that do not exist: {missing}'


def test_every_python_name_a_page_names_exists() -> None:
    named = {(page.relative_to(REPO).as_posix(), match.group(1))
             for page in _pages() for match in PYTHON_NAME.finditer(page.read_text())}
    assert len(named) > 50
    missing = sorted((page, name) for page, name in named if not _exists(name))
    assert missing == [], f'pages name modules or objects that do not exist: {missing}'


def test_the_messages_page_prints_every_message_file_whole() -> None:
    """docs/reference/messages.md holds each ``src/pd_msgs/msg/*.msg`` verbatim, and no other:
    a reader decodes the journal's and the topics' bytes from the page alone."""
    page = (REPO / 'docs' / 'reference' / 'messages.md').read_text()
    printed = dict(re.findall(r'^## (\w+)\n\n```text\n(.*?)\n```$', page,
                              re.MULTILINE | re.DOTALL))
    files = {path.stem: path.read_text().rstrip('\n')
             for path in (REPO / 'src' / 'pd_msgs' / 'msg').glob('*.msg')}
    assert sorted(printed) == sorted(files), 'docs/reference/messages.md: one section per .msg'
    for name, text in files.items():
        assert printed[name] == text, (
            f'docs/reference/messages.md: {name} differs from src/pd_msgs/msg/{name}.msg: '
            'copy the file into its block')


def test_the_command_line_reference_has_a_row_for_every_command() -> None:
    """Every command ``./pd help`` lists (the script's and every package's registered ones)
    has its row in docs/reference/cli.md's table, with where it is explained."""
    listed = set(re.findall(r'^  \./pd (\w+)', help_text(), re.MULTILINE))
    page = (REPO / 'docs' / 'reference' / 'cli.md').read_text()
    rows = set(re.findall(r'^\| `\./pd (\w+)', page, re.MULTILINE))
    assert listed, 'help_text lists no command'
    assert listed - rows == set(), f'docs/reference/cli.md: no row for {sorted(listed - rows)}'


def test_the_bag_snippets_of_analyse_a_bag_run_as_written(tmp_path: Path) -> None:
    """The Python of docs/how-to/analyse-a-bag.md, copied as it stands, reads a run's bag: the
    messages per topic and the peak force agree with the run's own outputs."""
    result = run_offline(load_test_file(DEFAULT_TEST, overrides={'duration': 3.0}),
                         tmp_path / 'run', figures=False)
    bag = result.directory / 'bag'
    page = (REPO / 'docs' / 'how-to' / 'analyse-a-bag.md').read_text()
    reader, read_bag = re.findall(r'```python\n(.*?)```', page, re.DOTALL)
    (tmp_path / 'read_bag.py').write_text(reader)
    (tmp_path / 'read_run.py').write_text(read_bag.replace("'runs/<run>/bag'", repr(str(bag))))
    steps = result.session.committed_step
    summary = json.loads((result.directory / 'summary.json').read_text())
    peak = summary['dofs']['top']['peaks']['restoring_force']['abs']
    out = subprocess.run([sys.executable, 'read_bag.py', str(bag)], cwd=tmp_path, text=True,
                         capture_output=True, timeout=120, check=True).stdout
    assert re.search(rf'^/pd/step_feedback +{steps + 1} messages$', out, re.MULTILINE), out
    assert f'peak restoring force {peak / 1000:.3f} kN' in out
    out = subprocess.run([sys.executable, 'read_run.py'], cwd=tmp_path, text=True,
                         capture_output=True, timeout=120, check=True).stdout
    assert out.startswith(f'{2 * (steps + 1)} commands and feedback;'), out
