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
