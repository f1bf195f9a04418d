"""The widgets in a real JupyterLab, and the documentation site, in Chromium (Debian's, driven by Playwright).

- ``test_explorers_follow_their_controls_in_jupyterlab`` starts JupyterLab on localhost (a token, a temporary root
  folder, its own config and settings folders), opens a copy of notebook 05 in Chromium that holds the code cells its
  explorers need (:func:`explorer_cells`: each cell that shows one, and the earlier cells that bind a name they read;
  nbval runs the whole notebook), runs it with *Run → Run All Cells* at the ``quick`` preset, then moves the
  interpolation explorer's ``t`` slider (arrow keys
  on its handle) and changes a dropdown of each explorer, and checks every time that the rendered picture (the
  ``ipywidgets.Image``) changes. ``OPNET_STATIC_WIDGETS`` is removed from the kernel's environment: the widgets are
  live here. The kernel reads and writes the data cache as the notebook does anywhere (``OPNET_DATA_DIR``, else
  ``~/.cache/opnet``): the networks it trains there are the ones the notebooks' own test (nbval) then loads, so the
  notebook's training is paid once per test run (about three and a half minutes from empty caches on 2 cores).
- ``test_tutorial_pages_show_their_figures_and_tables`` serves the documentation site (built once per session,
  the ``docs_site`` fixture shared with ``tests/test_docs_site.py``) on localhost and opens every tutorial page:
  each has figures, every ``<img>`` has loaded (``naturalWidth > 0``), at least as many as the notebook's saved
  image outputs, and each Markdown table the notebook displays is a rendered ``<table>``.

Both skip, saying why, where Playwright or ``/usr/bin/chromium`` is missing (``.ci/run`` installs Chromium; no
browser is ever downloaded). Screenshots are written into the test's temporary folder, never into the checkout.
"""

import ast
import functools
import http.server
import io
import json
import os
import secrets
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = Path("/usr/bin/chromium")
NOTEBOOK = ROOT / "notebooks" / "05_interpolation_analogy.ipynb"  # the notebook whose explorers are driven
#: Headless and off the network: without these flags Chromium's background connections are refused and it stalls.
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-quic",
    "--no-first-run",
]
STEP_MS = 60_000  # the longest wait of one step in the browser (a render after a control changes, a page load)
RUN_ALL_S = (
    900  # the copy's Run All: ~3.5 min from empty caches on 2 idle cores (training), seconds with the networks trained
)

sync_api = pytest.importorskip("playwright.sync_api", reason="needs Playwright: pip install -e '.[browser]'")
if not CHROMIUM.is_file():
    pytest.skip(
        f"needs Chromium at {CHROMIUM}: apt-get install chromium (.ci/run installs it)", allow_module_level=True
    )


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """A headless Chromium context with a fresh profile folder, the system browser's executable."""
    with sync_api.sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            str(tmp_path_factory.mktemp("chromium-profile")),
            executable_path=str(CHROMIUM),
            headless=True,
            args=CHROMIUM_ARGS,
            viewport={"width": 1500, "height": 1400},
        )
        context.set_default_timeout(STEP_MS)
        yield context
        context.close()


# -- JupyterLab ------------------------------------------------------------------------------------------------


class _Names(ast.NodeVisitor):
    """The names one statement reads and binds. An augmented assignment reads its target too; an item or attribute
    set (``d[k] = v``, ``o.a = v``) reads and binds its base name (a change to that object; a change through a method
    call, ``l.append(x)``, is not seen). A function, lambda or comprehension binds only its own name (a definition):
    what it reads from outside is read, its own variables are neither.
    """

    def __init__(self):
        self.reads, self.binds = set(), set()

    def visit_Name(self, node):
        (self.reads if isinstance(node.ctx, ast.Load) else self.binds).add(node.id)

    def _changed(self, node):
        self.generic_visit(node)
        if isinstance(node.ctx, ast.Store):
            base = node
            while isinstance(base, (ast.Subscript, ast.Attribute)):
                base = base.value
            if isinstance(base, ast.Name):
                self.reads.add(base.id)
                self.binds.add(base.id)

    visit_Subscript = visit_Attribute = _changed

    def visit_AugAssign(self, node):
        if isinstance(node.target, ast.Name):
            self.reads.add(node.target.id)
        self.generic_visit(node)

    def visit_Import(self, node):
        self.binds |= {(alias.asname or alias.name).split(".")[0] for alias in node.names}

    visit_ImportFrom = visit_Import

    def _scope(self, node, name=None):
        inner = _Names()
        for child in ast.iter_child_nodes(node):
            inner.visit(child)
        args = {a.arg for a in ast.walk(node) if isinstance(a, ast.arg)}
        self.reads |= inner.reads - inner.binds - args
        if name is not None:
            self.binds.add(name)

    def visit_FunctionDef(self, node):
        self._scope(node, node.name)

    visit_AsyncFunctionDef = visit_ClassDef = visit_FunctionDef
    visit_Lambda = visit_ListComp = visit_SetComp = visit_DictComp = visit_GeneratorExp = _scope


def _names(source: str) -> tuple[set, set]:
    """The names a cell binds, and those it reads before binding them (statement by statement, in order)."""
    bound, free = set(), set()
    for statement in ast.parse(source).body:
        names = _Names()
        names.visit(statement)
        free |= names.reads - bound
        bound |= names.binds
    return bound, free


def explorer_cells(cells: list) -> list:
    """The code cells of a notebook that its explorers need, in order: each cell that shows one (``widgets.show(``),
    and, for each name a needed cell reads, the last earlier cell that binds it (transitively)."""
    code = [c for c in cells if c["cell_type"] == "code"]
    sources = ["".join(c["source"]) for c in code]
    names = [_names(s) for s in sources]
    needed = {i for i, s in enumerate(sources) if "widgets.show(" in s}
    todo = sorted(needed)
    while todo:
        i = todo.pop()
        for name in names[i][1]:
            j = next((j for j in range(i - 1, -1, -1) if name in names[j][0]), None)
            if j is not None and j not in needed:
                needed.add(j)
                todo.append(j)
    return [code[i] for i in sorted(needed)]


def test_the_lab_copy_holds_the_explorers_and_what_they_read():
    """The slice of notebook 05 run in JupyterLab: every explorer, the set-up cell, and no cell that only measures
    (the applications table, the heads and hands); a cell that binds a name itself does not pull in an earlier one."""
    cells = json.loads(NOTEBOOK.read_text())["cells"]
    kept = ["".join(c["source"]) for c in explorer_cells(cells)]
    shows = sum("widgets.show(" in "".join(c["source"]) for c in cells)
    assert sum("widgets.show(" in s for s in kept) == shows >= 3
    assert "import opnet" in kept[0] and not any("applications_rows(" in s or "parts = {}" in s for s in kept)
    toy = [{"cell_type": "code", "source": s} for s in ("a = 1\nb = 2", "c = b", "a = 3\nwidgets.show(a + c)")]
    assert ["".join(c["source"]) for c in explorer_cells(toy)] == ["a = 1\nb = 2", "c = b", toy[2]["source"]]
    toy[2]["source"] = "a = 3\nwidgets.show(a, [b for b in range(a)])"
    assert explorer_cells(toy) == [toy[2]]
    for reads in ("a = a + 1", "a += 1", "for a in a:\n    pass", "d[0] = 1", "f = lambda: a"):  # read, then bound
        toy = [{"cell_type": "code", "source": s} for s in ("a = d = 1", f"{reads}\nwidgets.show(d, a)")]
        assert explorer_cells(toy) == toy, reads
    toy = [{"cell_type": "code", "source": s} for s in ("x = 1", "d = {}\nd['k'] = 2", "widgets.show(d)")]
    assert explorer_cells(toy) == toy[1:]  # the cell that changes d is kept, the one that binds x not
    toy = [
        {"cell_type": "code", "source": s} for s in ("x = 1", "def f(x):\n    y = x\n    return y", "widgets.show(f)")
    ]
    assert explorer_cells(toy) == toy[1:]  # a function's own variables bind nothing in the notebook


@pytest.fixture(scope="module")
def lab(tmp_path_factory, humans, quick_collection, free_port):
    """``(url, home)``: JupyterLab serving a folder with the slice of notebook 05 (outputs cleared); stopped afterwards.
    The quick humans and animals are in the data cache first (the fixtures), as notebook 02 leaves them.
    """
    home = tmp_path_factory.mktemp("jupyterlab")
    served = home / "root"
    served.mkdir()
    quick_collection("animals")  # the slice's section 6 reads them
    notebook = json.loads(NOTEBOOK.read_text())
    notebook["cells"] = explorer_cells(notebook["cells"])
    for cell in notebook["cells"]:
        cell["outputs"], cell["execution_count"] = [], None
    (served / NOTEBOOK.name).write_text(json.dumps(notebook, indent=1))
    env = {k: v for k, v in os.environ.items() if k != "OPNET_STATIC_WIDGETS"}
    env.update(
        OPNET_PRESET="quick",
        JUPYTER_CONFIG_DIR=str(home / "config"),
        JUPYTER_RUNTIME_DIR=str(home / "runtime"),
        JUPYTER_DATA_DIR=str(home / "data"),  # the notebook-signing key; the kernel is the environment's own
        JUPYTERLAB_SETTINGS_DIR=str(home / "settings"),
        JUPYTERLAB_WORKSPACES_DIR=str(home / "workspaces"),
    )
    settings = {  # no news or update check (a notification would ask), no kernel dialog: the notebook's kernel
        "apputils-extension/notification": {"fetchNews": "false", "checkForUpdates": False},
        # every cell laid out: off-screen cells are otherwise skipped (content-visibility), their text reads empty
        "notebook-extension/tracker": {"autoStartDefaultKernel": True, "windowingMode": "none"},
    }
    for name, values in settings.items():
        path = home / "settings" / "@jupyterlab" / f"{name}.jupyterlab-settings"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(values))
    port, token = free_port(), secrets.token_hex(16)
    command = [
        sys.executable,
        "-m",
        "jupyter",
        "lab",
        "--no-browser",
        f"--port={port}",
        "--ServerApp.ip=127.0.0.1",
        f"--IdentityProvider.token={token}",
        "--allow-root",  # a container's root (CI); the server listens on 127.0.0.1 only, behind the token
        f"--ServerApp.root_dir={served}",
        "--ServerApp.open_browser=False",
    ]
    log = (home / "server.log").open("w")
    server = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT, cwd=served)
    try:
        url = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 90
        while True:
            assert server.poll() is None, f"JupyterLab exited:\n{(home / 'server.log').read_text()[-4000:]}"
            try:
                with urllib.request.urlopen(f"{url}/api/status?token={token}", timeout=5) as r:
                    if r.status == 200:
                        break
            except OSError:
                pass
            assert time.monotonic() < deadline, f"JupyterLab did not answer:\n{(home / 'server.log').read_text()}"
            time.sleep(0.5)
        yield f"{url}/lab/tree/{NOTEBOOK.name}?token={token}", home
    finally:
        server.terminate()
        try:
            server.wait(30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        log.close()


def pixels(png: bytes) -> np.ndarray:
    import PIL.Image

    return np.asarray(PIL.Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def changed(before: bytes, after: bytes) -> float:
    """The fraction of pixels that differ between two screenshots (1 where their sizes differ)."""
    a, b = pixels(before), pixels(after)
    return 1.0 if a.shape != b.shape else float(np.mean(np.any(a != b, axis=-1)))


def test_explorers_follow_their_controls_in_jupyterlab(browser, lab, tmp_path):
    url, home = lab
    page = browser.new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    page.wait_for_selector(".jp-Notebook .jp-Cell")
    # the kernel is connected ("No Kernel | Initializing" before): a Run All sent earlier is lost
    page.locator(".jp-StatusBar-Widget", has_text="| Idle").first.wait_for()
    page.get_by_role("menuitem", name="Run", exact=True).click()
    page.get_by_role("menuitem", name="Run All Cells", exact=True).click()
    page.locator(".jp-InputPrompt", has_text="[*]").first.wait_for()  # queued or running

    outputs = page.locator(".jp-OutputArea-output")
    images = page.locator(".jp-OutputArea-output img.widget-image")
    running = page.locator(".jp-InputPrompt", has_text="[*]")  # cells queued or running
    deadline = time.monotonic() + RUN_ALL_S

    shown = sum("widgets.show(" in "".join(c["source"]) for c in json.loads(NOTEBOOK.read_text())["cells"])

    def done() -> bool:  # every cell has run, and every explorer shows a picture
        rendered = images.count() == shown and all(
            images.nth(i).evaluate("i => i.naturalWidth > 0") for i in range(shown)
        )
        return rendered and running.count() == 0

    while not done():
        if outputs.filter(has_text="Traceback").count() or time.monotonic() > deadline:
            page.screenshot(path=tmp_path / "failed.png", full_page=True)
            text, log = "\n".join(outputs.all_inner_texts()), (home / "server.log").read_text()
            pytest.fail(
                f"{NOTEBOOK.name} did not run to the end with its explorers rendered ({tmp_path / 'failed.png'}); "
                f"outputs:\n{text[-6000:]}\n"
                f"JupyterLab's log:\n{log[-3000:]}"
            )
        time.sleep(1.0)
    explorers = outputs.filter(has=page.locator("img.widget-image"))
    interpolation, analogy = explorers.nth(0), explorers.nth(1)

    def picture_changes(explorer, action, name):
        """Do ``action``, then wait for a new render of ``explorer``'s image and compare the two screenshots."""
        image = explorer.locator("img.widget-image")
        image.scroll_into_view_if_needed()
        src, before = image.get_attribute("src"), image.screenshot(path=tmp_path / f"{name}-before.png")
        action()
        page.wait_for_function("([img, src]) => img.src !== src && img.complete", arg=[image.element_handle(), src])
        after = image.screenshot(path=tmp_path / f"{name}-after.png")
        assert changed(before, after) > 0.001, f"{name}: the picture did not change ({tmp_path})"

    def another_option(select):  # the option after the selected one (the first after the last)
        return lambda: select.select_option(index=select.evaluate("s => (s.selectedIndex + 1) % s.options.length"))

    slider, readout = interpolation.locator(".widget-slider .noUi-handle"), interpolation.locator(".widget-readout")
    t = float(readout.inner_text())

    def move_slider():  # one step of the slider (0.1 at the explorer's 11 steps), back from its end
        slider.focus()
        slider.press("ArrowLeft" if t == 1.0 else "ArrowRight")

    picture_changes(interpolation, move_slider, "slider")
    assert float(readout.inner_text()) != t

    start = interpolation.locator(".widget-dropdown", has_text="start").locator("select")
    picture_changes(interpolation, another_option(start), "interpolation-dropdown")

    b_pose = analogy.locator(".widget-dropdown", has_text="B pose").locator("select")
    picture_changes(analogy, another_option(b_pose), "analogy-dropdown")
    for k in range(2, shown):  # the animals' analogy explorer (section 6): another species as B
        b_subject = explorers.nth(k).locator(".widget-dropdown", has_text="B subject").locator("select")
        picture_changes(explorers.nth(k), another_option(b_subject), f"explorer-{k}-dropdown")
    page.screenshot(path=tmp_path / "lab.png", full_page=True)
    assert not errors, errors
    page.close()


# -- the documentation site --------------------------------------------------------------------------------------


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def site(docs_site):
    """The built documentation site served on localhost: ``(base url, html folder)``."""
    if sys.version_info < (3, 11):
        pytest.skip("the documentation site needs Python 3.11 or later")
    out, result = docs_site  # a warning fails test_docs_site; the pages it leaves are written all the same
    assert (out / "tutorials").is_dir(), result.stderr[-6000:]
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(QuietHandler, directory=out))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}", out
    server.shutdown()
    server.server_close()


def image_outputs(notebook: Path) -> int:
    cells = json.loads(notebook.read_text())["cells"]
    return sum(any(k.startswith("image/") for k in o.get("data", {})) for c in cells for o in c.get("outputs", []))


def test_tutorial_pages_show_their_figures_and_tables(browser, site, markdown_tables, tmp_path):
    url, out = site
    notebooks = sorted((ROOT / "notebooks").glob("0*.ipynb"))
    assert notebooks and len(notebooks) == len(list((out / "tutorials").glob("0*.html")))
    page, problems = browser.new_page(), []
    for notebook in notebooks:
        page.goto(f"{url}/tutorials/{notebook.stem}.html", wait_until="load")
        # lazily loaded pictures load too, then every one must have decoded
        page.evaluate("() => document.querySelectorAll('img').forEach(i => { i.loading = 'eager'; })")
        page.wait_for_function("() => [...document.images].every(i => i.complete)")
        images = page.evaluate(
            "() => [...document.images].map(i => [i.getAttribute('src'), i.naturalWidth, !!i.closest('.cell_output')])"
        )
        figures, expected = sum(output for *_, output in images), image_outputs(notebook)
        if broken := [src for src, width, _ in images if width == 0]:
            problems.append(f"{notebook.stem}: pictures that did not load: {broken}")
        if figures == 0 or figures < expected:
            problems.append(f"{notebook.stem}: {figures} figures shown for the notebook's {expected} image outputs")
        tables = markdown_tables(notebook)
        rendered = page.evaluate(  # tables with rows that take up room on the page
            "() => [...document.querySelectorAll('article table')]"
            ".filter(t => t.querySelectorAll('tr').length > 1 && t.getBoundingClientRect().width > 0).length"
        )
        raw = page.evaluate(  # a table left as a paragraph of its source text
            "() => [...document.querySelectorAll('article p')]"
            ".filter(p => /^\\s*\\|.*\\|\\s*-{3}/s.test(p.textContent)).length"
        )
        if rendered < len(tables) or raw:
            problems.append(f"{notebook.stem}: {len(tables)} tables displayed, {rendered} rendered, {raw} left as text")
        page.screenshot(path=tmp_path / f"{notebook.stem}.png")
    page.close()
    assert not problems, "\n".join(problems)
