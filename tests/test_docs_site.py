"""The built documentation site (`make docs`, then `make test-docs`): every page built, every
internal link and image resolved, the generated references complete, and the pages rendered by
headless Chromium with their figures and formulas. Skipped without docs/_build/html."""

import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

from conftest import serial_only
from rodfem.cli import parser
from rodfem.scene.schema import SCHEMA

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "docs" / "_ext"))
import rodfem_reference  # noqa: E402

DOCS = Path(__file__).resolve().parent.parent / "docs"
HTML = DOCS / "_build" / "html"

pytestmark = [
    serial_only,
    pytest.mark.skipif(not (HTML / "index.html").is_file(),
                       reason="no built site in docs/_build/html: run `make docs` first"),
]


class Page(HTMLParser):
    """The links, images and element ids of one HTML page."""

    def __init__(self, path: Path):
        super().__init__()
        self.links, self.images, self.ids = [], [], set()
        self.feed(path.read_text(encoding="utf-8"))

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if "id" in attrs:
            self.ids.add(attrs["id"])
        if tag == "a" and attrs.get("href"):
            self.links.append(attrs["href"])
        if tag == "img" and attrs.get("src"):
            self.images.append(attrs["src"])


@pytest.fixture(scope="module")
def pages() -> dict[Path, Page]:
    return {path: Page(path) for path in HTML.rglob("*.html")}


def _local(reference: str) -> bool:
    return not urlsplit(reference).scheme and not reference.startswith("//")


def test_every_source_page_is_built():
    sources = [p for p in DOCS.rglob("*.md") if "_build" not in p.parts and "_ext" not in p.parts]
    assert len(sources) >= 20
    for source in sources:
        built = HTML / source.relative_to(DOCS).with_suffix(".html")
        assert built.is_file(), f"{source.relative_to(DOCS)} has no page"


def test_internal_links_resolve(pages):
    broken = []
    for path, page in pages.items():
        for href in filter(_local, page.links):
            target, fragment = urlsplit(href).path, urlsplit(href).fragment
            file = (path.parent / unquote(target)).resolve() if target else path
            if not file.exists():
                broken.append(f"{path.relative_to(HTML)}: {href}")
            elif fragment and file.suffix == ".html" and file in pages:
                if unquote(fragment) not in pages[file].ids:
                    broken.append(f"{path.relative_to(HTML)}: {href} (no such anchor)")
    assert not broken, "\n".join(broken)


def test_every_image_resolves_to_an_image(pages):
    from PIL import Image

    seen = 0
    for path, page in pages.items():
        for src in filter(_local, page.images):
            file = (path.parent / unquote(urlsplit(src).path)).resolve()
            assert file.is_file(), f"{path.relative_to(HTML)}: <img src={src!r}> is missing"
            with Image.open(file) as image:
                assert min(image.size) > 10, file
            seen += 1
    assert seen >= 20  # the figures of the pages and of the demos


def test_demos_ran_with_their_figures(pages):
    demos = sorted((DOCS.parent / "demos").glob("demo_*.py"))
    for demo in demos:
        page = HTML / "demos" / f"{demo.stem}.html"
        assert page.is_file(), demo.name
        assert "not run for this build" not in page.read_text(encoding="utf-8"), demo.name
    figured = HTML / "demos" / "demo_paper3.html"
    assert any(re.search(r"contact\d*\.png$", src) for src in pages[figured].images)


def test_scene_reference_lists_every_key():
    text = (HTML / "reference" / "scene.html").read_text(encoding="utf-8")
    for section, keys in SCHEMA.items():
        for name in keys:
            assert f'<span class="pre">{section}.{name}</span></code>' in text, name


def test_cli_reference_lists_every_option():
    text = (HTML / "reference" / "cli.html").read_text(encoding="utf-8")
    for command, strings in rodfem_reference.options(parser()).items():
        assert f'id="cli-{command}"' in text
        for string in strings:
            assert re.search(rf"<span class=\"pre\">[^<]*{re.escape(string)}\b", text), string


def _chromium() -> str:
    browser = shutil.which("chromium")
    if browser is None:
        pytest.skip("no chromium (scripts/setup.sh docs installs Debian's)")
    return browser


def _headless(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
                           "--hide-scrollbars", "--virtual-time-budget=10000", *args],
                          capture_output=True, text=True, timeout=120)


def test_index_renders_with_its_figure(tmp_path):
    from PIL import Image

    shot = tmp_path / "index.png"
    done = _headless("--window-size=1280,1400", f"--screenshot={shot}",
                     (HTML / "index.html").as_uri())
    assert shot.is_file(), done.stderr
    with Image.open(shot) as image:
        pixels = image.convert("RGB")
        colours = pixels.getcolors(maxcolors=1 << 20)
        assert image.size == (1280, 1400)
    # a page of text on white has a few hundred colours; the index's figure brings thousands
    assert colours is not None and len(colours) > 2000
    white = max(colours)[0] / (1280 * 1400)
    assert white < 0.9  # not blank


def test_formulas_are_typeset():
    """MathJax (copied into the site) turns the model page's TeX into rendered math offline."""
    done = _headless("--dump-dom", (HTML / "model.html").as_uri())
    assert done.stdout.count('class="mjx-chtml') >= 10, done.stderr[-2000:]


# Run in a page once MathJax has typeset it (MathJax 2's hooks): how wide the page is against
# the window, and each display equation's box, content width and overflow. The page is read
# from a copy whose <base> is the site, so that its styles and MathJax load as from the site.
MEASURE = """<script>
window.addEventListener("load", function () {  // MathJax itself loads asynchronously
 MathJax.Hub.Register.StartupHook("End", function () {  // after the page is typeset
 MathJax.Hub.Queue(function () {
  var displays = Array.prototype.map.call(document.querySelectorAll("div.math"), function (box) {
    return {right: box.getBoundingClientRect().right, content: box.scrollWidth,
            shown: box.clientWidth, typeset: box.querySelector(".mjx-chtml") !== null,
            overflow: getComputedStyle(box).overflowX};
  });
  document.body.setAttribute("data-measured", JSON.stringify({
    window: window.innerWidth, page: document.documentElement.scrollWidth, displays: displays}));
 });
 });
});
</script>"""


def _measured(page: Path, tmp_path: Path, width: int) -> dict:
    import json

    text = page.read_text(encoding="utf-8")
    base = f'<head><base href="{page.parent.as_uri()}/">'
    copy = tmp_path / page.name
    copy.write_text(text.replace("<head>", base, 1).replace("</body>", MEASURE + "</body>", 1),
                    encoding="utf-8")
    done = _headless(f"--window-size={width},900", "--dump-dom", copy.as_uri())
    found = re.search(r'data-measured="([^"]*)"', done.stdout)
    assert found, f"{page.name}: not measured\n{done.stderr[-2000:]}"
    return json.loads(found.group(1).replace("&quot;", '"'))


def test_wide_equations_scroll_in_their_box_on_a_phone(tmp_path):
    """At a phone's width (500 px, the narrowest window headless Chromium opens) no display
    equation widens the page or is cut off by it: each one wider than the page scrolls sideways
    in its own box (docs/_static/rodfem.css)."""
    with_math = [p for p in sorted(HTML.rglob("*.html"))
                 if '<div class="math notranslate' in p.read_text(encoding="utf-8")]
    assert len(with_math) >= 4  # the model, the time schemes and two demos
    wider = 0
    for page in with_math:
        measured = _measured(page, tmp_path, 500)
        displays = measured["displays"]
        assert measured["window"] == 500, measured["window"]
        assert displays and all(d["typeset"] for d in displays), page.name
        assert measured["page"] <= measured["window"], (page.name, measured["page"])
        for display in displays:
            assert display["right"] <= measured["window"] + 1, (page.name, display)
            if display["content"] > display["shown"]:
                assert display["overflow"] in ("auto", "scroll"), (page.name, display)
                wider += 1
    assert wider > 0  # some equations are wider than a phone: they are the ones that scroll


def test_api_reference_documents_the_api():
    import rodfem

    text = (HTML / "reference" / "api.html").read_text(encoding="utf-8")
    for name in rodfem._API:
        assert f'id="rodfem.{name}"' in text, name


def test_user_pages_speak_to_users(pages):
    """Development targets and issue numbers belong on the development page alone."""
    for path in pages:
        if path.name in ("development.html", "genindex.html", "search.html"):
            continue
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"\bissue \d|\bissues? #\d|\(issue", text, re.I), path.name
