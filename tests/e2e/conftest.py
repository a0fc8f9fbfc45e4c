"""Browser fixtures: a real `guided-sfm serve --sample` in a subprocess, its reconstructed sample
project, and headless Debian Chromium driven by Playwright (no browser download)."""

from __future__ import annotations

import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import pytest

from tests.required import missing, services_required

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]
ARTIFACTS = Path(__file__).resolve().parents[2] / "test-artifacts"
START_TIMEOUT_S = 300  # migrations, sample rendering and the first answer of the API
JOB_TIMEOUT_S = 1800  # one reconstruction or apply of the sample on 2 shared cores
TERMINAL = {"succeeded", "failed", "cancelled"}


NO_CHROMIUM = f"{CHROMIUM} is missing: the browser tests drive Debian's chromium"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Without Chromium the browser tests skip before starting anything, unless services are
    required (CI): then the `browser` fixture fails them."""
    if CHROMIUM.exists() or services_required():
        return
    for item in items:
        if "browser" in item.keywords:
            item.add_marker(pytest.mark.skip(reason=NO_CHROMIUM))


@dataclass
class Server:
    url: str
    username: str
    password: str
    data_dir: Path
    process: subprocess.Popen
    log: Path
    token: str = ""
    client: httpx.Client = field(default_factory=lambda: httpx.Client(timeout=60))

    @property
    def api(self) -> str:
        return self.url.rstrip("/") + "/api/v1"

    def headers(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.token}"}

    def get(self, path: str, **kwargs) -> object:
        response = self.client.get(self.api + path, headers=self.headers(), **kwargs)
        response.raise_for_status()
        return response.json()

    def request(self, method: str, path: str, **kwargs) -> httpx.Response:
        return self.client.request(method, self.api + path, headers=self.headers(), **kwargs)

    def wait_job(self, job_id: int, timeout: float = JOB_TIMEOUT_S) -> dict:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            job = self.get(f"/jobs/{job_id}")
            if job["state"] in TERMINAL:
                return job
            time.sleep(2)
        raise TimeoutError(f"job {job_id} did not finish within {timeout} s")


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def read_banner(process: subprocess.Popen, log: Path) -> dict[str, str]:
    """The URL:, Username: and Password: lines `serve --sample` prints once the API answers."""
    lines: queue.Queue[str] = queue.Queue()
    # Drain stdout for the server's whole life, so a full pipe never blocks it.
    threading.Thread(target=lambda: [lines.put(line) for line in process.stdout], daemon=True).start()
    found: dict[str, str] = {}
    deadline = time.monotonic() + START_TIMEOUT_S
    while len(found) < 3:
        if process.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"`guided-sfm serve` ended or stalled before its banner; see {log}")
        try:
            line = lines.get(timeout=1)
        except queue.Empty:
            continue
        match = re.match(r"^(URL|Username|Password):\s*(\S+)\s*$", line.strip())
        if match:
            found[match.group(1)] = match.group(2)
    return found


def stop(process: subprocess.Popen) -> None:
    """End the server and the worker it started: its own process group, which we created."""
    if process.poll() is not None:
        return
    os.killpg(process.pid, signal.SIGTERM)
    try:
        process.wait(timeout=60)  # serve stops its API and worker, each with a grace period
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=10)


# A data dir to keep between runs (opt-in): `serve --sample` reuses its sample project, so a rerun
# starts in seconds instead of reconstructing the sample again. Unset: a fresh temporary one.
REUSE_DATA_DIR = "GUIDED_SFM_E2E_DATA_DIR"


@pytest.fixture(scope="session")
def server(tmp_path_factory) -> Iterator[Server]:
    kept = os.environ.get(REUSE_DATA_DIR)
    data_dir = Path(kept) if kept else tmp_path_factory.mktemp("gsfm-e2e")
    data_dir.mkdir(parents=True, exist_ok=True)
    log = data_dir / "serve.log"
    command = [str(Path(sys.executable).with_name("guided-sfm")), "serve", "--data-dir", str(data_dir),
               "--port", str(free_port()), "--sample"]
    with log.open("w") as stderr:
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=stderr, text=True,
                                   start_new_session=True)
    try:
        banner = read_banner(process, log)
        srv = Server(banner["URL"], banner["Username"], banner["Password"], data_dir, process, log)
        response = srv.client.post(srv.api + "/auth/token",
                                   data={"username": srv.username, "password": srv.password})
        response.raise_for_status()
        srv.token = response.json()["access_token"]
        yield srv
        srv.client.close()
    finally:
        stop(process)
        process.stdout.close()


@pytest.fixture(scope="session")
def sample_project(server: Server) -> dict:
    """The sample project once its reconstruction job has succeeded."""
    projects = server.get("/projects")
    assert projects, "serve --sample created no project"
    project = projects[0]
    for job in server.get(f"/projects/{project['id']}/jobs"):
        if job["state"] not in TERMINAL:
            job = server.wait_job(job["id"])
        assert job["state"] == "succeeded", f"the sample's {job['kind']} job {job['state']}: {job['error']}"
    project = server.get(f"/projects/{project['id']}")
    assert project["head_version_id"] is not None, "the sample has no version after its jobs"
    return project


@pytest.fixture(scope="session")
def playwright_driver() -> Iterator[object]:
    """One Playwright for the whole run: a second sync_playwright() while one runs is refused
    ("Sync API inside the asyncio loop"), so every browser is launched from this one."""
    if not CHROMIUM.exists():
        missing(NO_CHROMIUM)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        yield playwright


@pytest.fixture(scope="session")
def browser(playwright_driver) -> Iterator[object]:
    chromium = playwright_driver.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
    yield chromium
    chromium.close()


class ConsoleLog:
    """Console errors and uncaught exceptions of a page; `allow` holds patterns a test expects."""

    def __init__(self) -> None:
        self.errors: list[str] = []
        self.allow: list[str] = []

    def on_console(self, message) -> None:
        if message.type == "error":
            self.errors.append(message.text)

    def on_error(self, error) -> None:
        self.errors.append(f"uncaught: {error}")

    def unexpected(self) -> list[str]:
        return [e for e in self.errors if not any(re.search(p, e) for p in self.allow)]


@pytest.fixture
def console() -> ConsoleLog:
    return ConsoleLog()


@pytest.fixture
def page(browser, console: ConsoleLog, request) -> Iterator[object]:
    context = browser.new_context(viewport={"width": 1440, "height": 900})
    page = context.new_page()
    page.set_default_timeout(30_000)
    page.on("console", console.on_console)
    page.on("pageerror", console.on_error)
    yield page
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=ARTIFACTS / f"{request.node.name}-last.png")
    context.close()
    assert not console.unexpected(), f"console errors: {console.unexpected()}"


def shot(page, name: str) -> None:
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=ARTIFACTS / f"{name}.png")


def sign_in(page, server: Server) -> None:
    page.goto(server.url)
    form = page.locator("#sign-in-form")
    form.get_by_label("Username").fill(server.username)
    form.get_by_label("Password").fill(server.password)
    form.get_by_role("button", name="Sign in").click()
    page.wait_for_selector("body[data-ready=projects]")
