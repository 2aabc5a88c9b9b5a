"""The first page: README.md fits on a few screens, names the test command the continuous
integration runs, tells how to run MPI as root and with more ranks than cores (the variables the
Makefile itself sets), and every file and section it links to exists."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
MAX_LINES = 200


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def mpirun_variables() -> list[str]:
    """The environment variables of the Makefile's MPIRUN (root allowed, oversubscription)."""
    makefile = _text(ROOT / "Makefile").replace("\\\n", " ")
    line = next(line for line in makefile.splitlines() if line.startswith("MPIRUN :="))
    return re.findall(r"([A-Z][A-Za-z0-9_]+)=\S+", line)


def test_readme_is_short():
    lines = _text(README).splitlines()
    assert len(lines) <= MAX_LINES, f"README.md has {len(lines)} lines; keep it to {MAX_LINES}"


def test_readme_names_the_test_command_ci_runs():
    assert re.search(r"^make test\s", _text(ROOT / ".ci" / "run"), re.M)
    assert re.search(r"^make test +# ", _text(README), re.M)


def test_mpi_as_root_and_oversubscribed_is_explained():
    names = mpirun_variables()
    assert {"OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM",
            "OMPI_MCA_rmaps_base_oversubscribe", "PRTE_MCA_rmaps_default_mapping_policy"} <= set(
        names)
    readme = _text(README)
    running = _text(ROOT / "docs" / "running.md")
    assert "## Running with MPI" in readme and "## Running with MPI" in running
    makefile = _text(ROOT / "Makefile").replace("\\\n", " ")
    for name in names:
        setting = re.search(rf"{name}=\S+", makefile).group(0)
        assert setting in readme, setting
        assert setting in running, setting
    assert "--oversubscribe" in readme and "--oversubscribe" in running


def _anchor(heading: str) -> str:
    """The anchor of a Markdown heading, as GitHub and MyST make it."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def test_readme_links_resolve():
    links = re.findall(r"\]\(([^)\s]+)\)", _text(README))
    assert len(links) > 10
    for link in links:
        if re.match(r"[a-z]+://", link):
            continue
        target, _, anchor = link.partition("#")
        path = ROOT / target
        assert path.exists(), link
        if anchor:
            headings = re.findall(r"^#+ (.+)$", _text(path), re.M)
            assert anchor in {_anchor(h) for h in headings}, link
