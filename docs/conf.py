"""Sphinx configuration of the opnet documentation site: ``make docs`` builds it into ``build/docs/``.

Markdown pages and the committed (already executed) notebooks go through myst-nb, which renders the stored
outputs without running anything; the API reference comes from the numpy-style docstrings (autodoc + numpydoc).
The build is nitpicky (``-n -W``): every cross-reference must resolve. Nothing is fetched at build or view time:
no intersphinx, no CDN scripts (math is rendered to MathML at build time, see ``mathml`` below).
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
from pathlib import Path
from types import ModuleType

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.ext.autosummary import Autosummary

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the checkout's opnet, installed or not

import opnet  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent / "_scripts"))
from generated import write_benchmark_fragments, write_results_fragments  # noqa: E402

write_benchmark_fragments(Path(__file__).resolve().parent / "_generated" / "benchmarks")
write_results_fragments(Path(__file__).resolve().parent / "_generated" / "results")
write_results_fragments(Path(__file__).resolve().parent / "_generated" / "results-animals", collection="animals")

project = "opnet"
author = "the opnet authors"
copyright = "2026, the opnet authors"
version = release = opnet.__version__

extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.autosummary", "numpydoc"]
exclude_patterns = ["_build", "_generated", "_scripts", "**/.ipynb_checkpoints"]
nitpicky = True

# -- pages and notebooks (myst-nb) -------------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath"]  # the notebooks write display math as $$ ... $$, as Jupyter does
myst_heading_anchors = 3
nb_execution_mode = "off"  # the committed notebooks are executed (quick preset): render their outputs as stored
nb_ipywidgets_js = {}  # no require.js / widget manager from a CDN: widget outputs fall back to their text or image
nb_mime_priority_overrides = [("html", "application/vnd.jupyter.widget-view+json", None)]
nb_merge_streams = True
# a notebook's `display(Markdown(...))` outputs are parsed as MyST (the pages' own syntax, tables included), not as
# CommonMark, which has no tables and showed them as one paragraph of `| ... |` text
nb_render_markdown_format = "myst"

# -- API reference (autodoc + autosummary + numpydoc) ------------------------------------------------------------
autodoc_default_options = {"members": True, "undoc-members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
autosummary_generate = False  # the public-API tables link to the module pages; no generated stub files
# numpydoc (numpy's and scipy's own): free-form types such as "(n, 3) float64" stay text, and module constants'
# doc-comments are not parsed as "type: description" (napoleon reads "Named gestures: ..." as a type)
numpydoc_show_class_members = False  # autodoc lists the members itself
numpydoc_xref_param_type = False

# External types (numpy, scipy, torch, ...) cannot resolve without intersphinx, which needs the network at build
# time: they are shown as written, unlinked.
nitpick_ignore_regex = [
    (r"py:.*", r"(np|numpy|scipy|sp|torch|nn|trimesh|pyvista|pv|matplotlib|plt|ipywidgets|joblib|anny)(\..*)?"),
    (r"py:.*", r"(pathlib|os|typing|collections|dataclasses|argparse)\..*"),  # the standard library's, in type hints
]

# -- HTML (pydata-sphinx-theme; fonts and icons are bundled with the theme) ---------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"opnet {release}"
html_math_renderer = "mathml"
html_show_sourcelink = False
html_static_path = ["_static"]
html_css_files = ["opnet.css"]
# Pages without sub-pages need no left sidebar (it would hold only its title): the tables get the room.
html_sidebars = {
    page: []
    for page in ("index", "install", "inner_products", "own_meshes", "data", "notation", "results", "benchmarks")
}
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "navbar_align": "left",
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}


# -- local extensions ---------------------------------------------------------------------------------------------
def mathml(latex: str, display: str) -> str:
    """LaTeX rendered to MathML at build time (latex2mathml): browsers show it natively, with no MathJax download."""
    from latex2mathml.converter import convert

    return convert(latex, display=display)


def _visit_math(self, node):
    self.body.append(mathml(node.astext(), "inline"))
    raise nodes.SkipNode


def _visit_math_block(self, node):
    self.body.append(f'<div class="math notranslate nohighlight">{mathml(node.astext(), "block")}</div>')
    raise nodes.SkipNode


# tqdm's progress bars in the notebooks are widgets; stored without their state, all that remains is their first
# text ("0%| | 0/8"), which would read as a stalled computation: those outputs are left out of the pages.
_PROGRESS_PLACEHOLDER = re.compile(r"[^\n]*:\s+0%\|\s*\| 0/\d+ \[00:00<\?, \?[\w/]+\]")


def _drop_progress_placeholders(app, doctree):
    for block in list(doctree.findall(nodes.literal_block)):
        if "text_plain" in block["classes"] and _PROGRESS_PLACEHOLDER.fullmatch(block.astext().strip()):
            block.parent.remove(block)


class PublicAPI(Autosummary):
    """``{public-api} opnet``: the autosummary table of a module's ``__all__``, so it never drifts from the code."""

    required_arguments = 1

    def run(self):
        module = importlib.import_module(self.arguments[0])
        self.env.ref_context["py:module"] = module.__name__  # names relative to the package, as it exports them
        self.content = StringList(list(module.__all__), source=f"{module.__name__}.__all__")
        return super().run()


def _public_alias(app, env, node, contnode):
    """Resolve a name the way Python would, to where the object is defined and documented.

    ``opnet.eigenbasis`` (the public name) is documented as ``opnet.spectral.eigenbasis``; a docstring of
    ``opnet.data.generators`` may name ``CollectionError``, which it imports from ``opnet.data.storage``.
    """
    if node.get("refdomain") != "py" or node.get("reftype") == "mod":
        return None
    target = node["reftarget"].lstrip("~.")
    module, cls = node.get("py:module"), node.get("py:class")
    candidates = [f"{module}.{cls}.{target}"] if module and cls else []
    candidates += [f"{module}.{target}"] if module else []
    candidates.append(target)
    for candidate in candidates:
        real = _defined_at(candidate)
        if real is None or real == target:
            continue
        new = node.deepcopy()
        new["reftarget"] = real
        resolved = env.domains["py"].resolve_xref(
            env, node["refdoc"], app.builder, node["reftype"], real, new, contnode
        )
        if resolved is not None:
            return resolved
    return None


def _defined_at(dotted: str) -> str | None:
    """The defining module's name for the object ``dotted`` names (``opnet.X.attr``), or None."""
    parts = dotted.split(".")
    if parts[0] != "opnet":
        return None
    obj, owner = importlib.import_module("opnet"), None
    for i, part in enumerate(parts[1:], 1):
        owner, obj = obj, getattr(obj, part, None)
        if obj is None:  # a submodule not imported yet
            try:
                obj = importlib.import_module(".".join(parts[: i + 1]))
            except ImportError:
                return None
        if isinstance(obj, ModuleType):
            continue
        if inspect.isclass(obj) or inspect.isroutine(obj):
            home = f"{obj.__module__}.{obj.__qualname__}"
        else:  # data: the module that lists it in __all__
            if not isinstance(owner, ModuleType):
                return None
            home = next((m for m in _submodules(owner) if part in getattr(m, "__all__", ())), owner).__name__
            home = f"{home}.{part}"
        return ".".join([home, *parts[i + 1 :]])
    return obj.__name__


def _submodules(package: ModuleType) -> list[ModuleType]:
    """The public modules of a package (none for a module)."""
    if not hasattr(package, "__path__"):
        return []
    folder = Path(package.__path__[0])
    names = [p.stem for p in sorted(folder.glob("*.py")) if not p.stem.startswith("_")]
    return [importlib.import_module(f"{package.__name__}.{n}") for n in names]


def setup(app):
    app.add_html_math_renderer("mathml", (_visit_math, None), (_visit_math_block, None))
    app.add_directive("public-api", PublicAPI)
    app.connect("missing-reference", _public_alias)
    app.connect("doctree-read", _drop_progress_placeholders)
    return {"parallel_read_safe": True}
