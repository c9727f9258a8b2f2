"""The live console in a real browser (headless Chromium driven by selenium).

A simulated default test runs through the graph (``run_test``, dt 0.002 s so that it lasts
about half a minute); ``./pd console`` watches it. In the browser: the plots update while
it runs; an unauthenticated page's control is refused (403) and the test keeps running; the
page logs in with the token the console printed, pauses the test and resumes it (the
integrator's status really goes PAUSED, then RUNNING), presses the emergency stop (HOLDING),
then aborts it; the finished run then opens in the page (``console RUN``). A screenshot of
the live page is saved (to docs/figures/console.png with ``PD_UPDATE_SCREENSHOTS=1``).
"""

from __future__ import annotations

import os
import re
import shutil
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from graph_support import DOMAINS, REPO, Processes, executable, worker_index
from test_graph import call_service, latched_qos, run_launcher, spin_until, write_test_file

pytestmark = pytest.mark.graph

CHROMIUM = Path('/usr/bin/chromium')
CHROMEDRIVER = Path('/usr/bin/chromedriver')
SCREENSHOT = REPO / 'docs' / 'figures' / 'console.png'


@pytest.fixture
def domain_id() -> int:
    """The console's tests take domains 180-189 (distinct per xdist worker)."""
    return 180 + (5 * worker_index() + next(DOMAINS) % 5) % 10


@pytest.fixture
def browser(tmp_path: Path) -> Iterator[Any]:
    """Headless Chromium (Debian's package) with a fresh profile, closed after the test."""
    if not (CHROMIUM.is_file() and CHROMEDRIVER.is_file()):
        pytest.fail('chromium and chromium-driver are not installed (scripts/setup.sh '
                    'installs them)')
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for argument in ('--headless', '--no-sandbox', '--disable-gpu', '--disable-quic',
                     '--no-first-run', '--disable-background-networking',
                     '--disable-component-update', '--disable-sync',
                     f'--user-data-dir={tmp_path / "chromium"}', '--window-size=1400,1500'):
        options.add_argument(argument)
    driver = webdriver.Chrome(options=options, service=Service(str(CHROMEDRIVER),
                                                               log_output=str(
                                                                   tmp_path / 'driver.log')))
    try:
        yield driver
    finally:
        driver.quit()


def wait_for(predicate: Callable[[], bool], timeout: float, what: str,
             tick: Callable[[], None] | None = None) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f'timed out after {timeout} s waiting for {what}')
        if tick is not None:
            tick()
        else:
            time.sleep(0.05)


def points(driver: Any) -> int:
    """Points drawn on the first displacement plot."""
    value = driver.execute_script(
        "const c = document.querySelector('canvas.displacement');"
        'return c ? Number(c.dataset.points || 0) : 0;')
    return int(value)


def test_the_console_shows_and_steers_a_running_test_in_a_browser(
        processes: Processes, observer: Any, browser: Any, key_file: Path,
        tmp_path: Path) -> None:
    from selenium.webdriver.common.by import By

    from pd_msgs.msg import TestStatus

    statuses: list[Any] = []
    observer.create_subscription(TestStatus, '/pd/test_status', statuses.append,
                                 latched_qos())
    test_file = write_test_file(tmp_path / 'console.yaml', test__id='graph-console')
    launcher = run_launcher(processes, 'run_test', [
        str(test_file), '--out', str(tmp_path / 'run'), '--key', str(key_file),
        '--no-figures', '-p', 'dt:=0.002'])
    console = processes.start('console', [executable('pd_console', 'console'),
                                          '--port', '0', '--key', str(key_file)])

    def console_said(pattern: str) -> str:
        found = re.search(pattern, processes.log('console'))
        return found.group(1) if found else ''

    wait_for(lambda: bool(console_said(r'login token \(one use\): (\S+)')), 20.0,
             'the console to print its token')
    url = console_said(r'serving (http://127\.0\.0\.1:\d+/)')
    token = console_said(r'login token \(one use\): (\S+)')
    assert console.poll() is None

    def spin() -> None:
        observer.executor_for_test.spin_once(timeout_sec=0.05)

    def state() -> int | None:
        return int(statuses[-1].state) if statuses else None

    spin_until(observer, lambda: state() == TestStatus.STATE_RUNNING, 60.0,
               lambda: 'the test to run; run_test said ' + processes.log('run_test')[-2000:])

    # -- the page watches: frames arrive and the plots grow while the test runs ------------
    browser.get(url)
    wait_for(lambda: points(browser) > 10, 20.0, 'the first plotted points', spin)
    # Frames first: a frame that lands between the two reads is then counted after them.
    frames = int(browser.execute_script('return Number(document.body.dataset.frames)'))
    first = points(browser)
    wait_for(lambda: points(browser) > first + 20, 10.0, 'the plots to update', spin)
    assert int(browser.execute_script('return Number(document.body.dataset.frames)')) > frames
    assert browser.find_element(By.ID, 'state').text == 'RUNNING'
    assert browser.find_element(By.ID, 'btn-pause').get_attribute('disabled') is not None

    # -- not logged in: a control is refused with 403 and nothing happens ------------------
    refused = browser.execute_async_script(
        'const done = arguments[arguments.length - 1];'
        "fetch('/api/control', {method: 'POST', headers: {'Content-Type': 'application/json'},"
        " body: JSON.stringify({command: 'pause'})}).then(r => done(r.status));")
    assert refused == 403
    before = statuses[-1].step
    spin_until(observer, lambda: statuses[-1].step > before + 50, 10.0,
               'the test to keep running after the refused pause')
    assert state() == TestStatus.STATE_RUNNING

    # -- log in with the printed token ------------------------------------------------------
    browser.find_element(By.ID, 'login-token').send_keys(token)
    browser.find_element(By.ID, 'login-button').click()
    wait_for(lambda: 'logged in' in browser.find_element(By.ID, 'auth-state').text, 10.0,
             'the login')
    time.sleep(0.6)  # a few more frames on the plots for the screenshot
    shot = tmp_path / 'console.png'
    browser.save_screenshot(str(shot))
    assert shot.stat().st_size > 20_000  # a rendered page, not a blank one
    if os.environ.get('PD_UPDATE_SCREENSHOTS') == '1':  # refresh the README's picture
        SCREENSHOT.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(shot, SCREENSHOT)

    def press(button: str) -> None:
        browser.find_element(By.ID, button).click()
        wait_for(lambda: browser.find_element(By.ID, 'confirm').get_attribute('open')
                 is not None, 5.0, 'the confirmation dialog')
        browser.find_element(By.ID, 'confirm-ok').click()

    # -- pause and resume from the page: the integrator's status shows them ----------------
    press('btn-pause')
    spin_until(observer, lambda: state() == TestStatus.STATE_PAUSED, 15.0, 'PAUSED')
    wait_for(lambda: browser.find_element(By.ID, 'state').text == 'PAUSED', 10.0,
             'the page to show PAUSED', spin)
    paused_at = statuses[-1].step
    press('btn-resume')
    spin_until(observer, lambda: state() == TestStatus.STATE_RUNNING
               and statuses[-1].step > paused_at, 15.0, 'RUNNING again')

    # -- the emergency stop (no confirmation, no login needed) holds the test --------------
    browser.find_element(By.ID, 'estop').click()
    spin_until(observer, lambda: state() == TestStatus.STATE_HOLDING, 15.0,
               'HOLDING after the emergency stop')
    # (held, it waits:) with a key the console is sealed like every node: nobody re-points
    # it (its port, its key) through set_parameters.
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    setting = SetParameters.Request(parameters=[Parameter(name='key_file', value=ParameterValue(
        type=ParameterType.PARAMETER_STRING, string_value=str(tmp_path / 'rogue.key')))])
    results = call_service(observer, SetParameters, '/pd/pd_console/set_parameters',
                           setting).results
    assert results and not results[0].successful and 'sealed' in results[0].reason, results

    # -- a cancelled confirmation sends nothing; then abort ends the test ------------------
    browser.find_element(By.ID, 'btn-abort').click()
    browser.find_element(By.ID, 'confirm-cancel').click()
    assert browser.find_element(By.ID, 'last-result').text == 'cancelled'
    press('btn-abort')
    spin_until(observer, lambda: state() == TestStatus.STATE_ABORTED, 15.0, 'ABORTED')
    launcher.wait(timeout=30.0)
    log = processes.log('console')
    assert 'control pause sent' in log and 'EMERGENCY STOP sent' in log

    # -- the finished run in the same page: its histories from the bag ---------------------
    processes.start('console_run', [executable('pd_console', 'console'),
                                    str(tmp_path / 'run'), '--port', '0'])
    wait_for(lambda: 'serving' in processes.log('console_run'), 20.0, 'the run console')
    found = re.search(r'serving (http://127\.0\.0\.1:\d+/)', processes.log('console_run'))
    assert found is not None
    browser.get(found.group(1))
    wait_for(lambda: points(browser) > 10, 20.0, "the run's plotted history")
    assert browser.execute_script('return document.body.dataset.mode') == 'run'
    assert browser.find_element(By.ID, 'state').text == 'ABORTED'
    assert browser.find_element(By.ID, 'btn-pause').get_attribute('disabled') is not None
