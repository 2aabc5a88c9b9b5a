"""Sphinx configuration of rodfem's documentation site (``make docs``)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent / "_ext"))

import rodfem  # noqa: E402

project = "rodfem"
author = "the rodfem developers"
copyright = "the rodfem developers, MIT licence"
release = version = rodfem.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "rodfem_docs",  # the generated pages: scene and CLI references, the demos run
]
source_suffix = {".md": "markdown"}
exclude_patterns = ["_build", "_ext", "**/.ipynb_checkpoints"]
root_doc = "index"
# Help texts and commands are shown as written: "--set" stays two hyphens
smartquotes = False

# MyST: $…$ and $$…$$ math, amsmath environments, ::: fences, anchors on headings (level ≤ 3)
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
myst_dmath_double_inline = True

# Every reference must resolve. The API's docstrings name rodfem's internal modules and the
# third-party types of its signatures, which this site does not document: those alone are let be.
nitpicky = True
nitpick_ignore_regex = [
    (r"py:.*", r"(rodfem|forms)\..*"),
    (r"py:.*", r"(FieldsError|FUNCTIONS|RunDirectoryError)"),
    (r"py:class", r"(np|numpy|MPI|mpi4py|pathlib|collections\.abc|typing)\..*"),
    (r"py:class", r"(Path|Mapping|Scene|Sweep|SweepResult|Any|Callable|Sequence|Iterable)"),
]

autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_default_options = {"members": True}
napoleon_google_docstring = True
napoleon_numpy_docstring = False

html_theme = "furo"
html_title = f"rodfem {release}"
# rodfem.css: display equations wider than the page scroll in their own box.
html_static_path = ["_static"]
html_css_files = ["rodfem.css"]
html_show_sourcelink = False
# MathJax 2 from Debian (libjs-mathjax), copied into _static/mathjax by rodfem_docs: the pages
# render their formulas without a network.
# MyST's own MathJax set-up is MathJax 3's: left out, MathJax 2 finds Sphinx's \( \) and \[ \].
if Path("/usr/share/javascript/mathjax/MathJax.js").is_file():
    mathjax_path = "mathjax/MathJax.js?config=TeX-AMS_CHTML"
    mathjax2_config = {"tex2jax": {"inlineMath": [["\\(", "\\)"]],
                                   "displayMath": [["\\[", "\\]"]]},
                       "showMathMenu": False, "messageStyle": "none"}
    myst_update_mathjax = False
