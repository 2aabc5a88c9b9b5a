#!/usr/bin/env bash
# Bring a Debian root machine to a working rodfem: Debian's FEniCSx packages, a virtual environment
# .venv made from /usr/bin/python3 with --system-site-packages, and rodfem installed into it
# (editable), and what a first run would compile compiled (rodfem prepare). Idempotent: a second
# run checks and changes nothing. The container runs this too.
# Debian 12 (dolfinx 0.5.2, Python 3.11, NumPy 1) and Debian 13 (dolfinx 0.9.0, Python 3.13,
# NumPy 2) alike: `make container-test` runs it in a Debian 13 chroot.
#
# `scripts/setup.sh docs` (what `make docs` runs) adds what the documentation site needs: Sphinx,
# MyST, the Furo theme, MathJax and headless Chromium from Debian (every name packaged by both
# releases), and jupytext from PyPI (the `docs` extra). The plain set-up, and so the containers,
# install none of it.
set -euo pipefail
cd "$(dirname "$0")/.."

# Every name must exist in both releases (libgl1, say, not bookworm's libgl1-mesa-glx).
APT_PACKAGES=(
  python3-dolfinx python3-petsc4py python3-mpi4py python3-ufl python3-basix python3-ffcx
  python3-slepc4py  # rodfem steady on fine meshes: the rightmost eigenvalues (Debian 12, 13, sid)
  python3-meshio python3-h5py python3-scipy python3-numpy python3-venv python3-pip python3-cffi
  python3-packaging  # reads Debian's packages' requirements into pip's constraints (below)
  openmpi-bin libopenmpi-dev build-essential
  python3-mpmath  # the tests: high-precision references of the contact laws
  python3-hypothesis  # the tests: property-based fuzzing of scene loading
  python3-pytest-xdist  # the tests: the serial suite dealt to a process per core (make test)
  # rodfem plot: pyvista's matplotlib built for Debian's NumPy; VTK's wheel dlopen()s libEGL.so.1
  # at run time (ldd shows no GL library) and Mesa renders off-screen with libgl1-mesa-dri.
  python3-matplotlib libegl1 libgl1-mesa-dri
  # rodfem's results as tables and labelled arrays (Result.to_pandas, Fields.to_xarray): Debian's,
  # built for its NumPy (pip's pandas would bring its own NumPy requirement)
  python3-pandas python3-xarray
)
extras=test
if [ "${1:-}" = docs ]; then
  extras=test,docs
  APT_PACKAGES+=(
    python3-sphinx python3-myst-parser furo  # the site: Sphinx 5.3 and MyST 0.18 on Debian 12
    libjs-mathjax fonts-mathjax  # MathJax 2, copied into the site: it renders without a network
    python3-nbformat  # jupytext's notebooks (its other requirements come with MyST)
    chromium  # tests/test_docs_site.py looks at the built pages in headless Chromium
  )
elif [ -n "${1:-}" ]; then
  echo "usage: scripts/setup.sh [docs]" >&2
  exit 2
fi

missing=()
for pkg in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ((${#missing[@]})); then
  if [ "$(id -u)" != 0 ]; then
    echo "setup: missing Debian packages (${missing[*]}); run as root to install them" >&2
    exit 1
  fi
  echo "setup: apt-get install ${missing[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" \
    >/dev/null
fi

if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv from /usr/bin/python3 (--system-site-packages)"
  /usr/bin/python3 -m venv --system-site-packages .venv
fi

# Debian's petsc4py and dolfinx are built against the system NumPy: pin pip to exactly that one,
# which the venv sees through --system-site-packages, so pip installs no NumPy at all (on Debian 12
# numpy==1.24.2, so numpy<2: NumPy 2 breaks their import; and not 1.26 either, which pip's own
# matplotlib would pull in: that is why matplotlib comes from Debian too).
numpy_pin=$(/usr/bin/python3 -c 'import numpy; print("numpy==" + numpy.__version__)')
stamp=.venv/.rodfem-installed
[ "$extras" = test ] || stamp=.venv/.rodfem-installed-$extras
if [ ! -f "$stamp" ] || [ pyproject.toml -nt "$stamp" ] || [ "$0" -nt "$stamp" ]; then
  echo "setup: pip install -e .[$extras] ($numpy_pin)"
  echo "$numpy_pin" > .venv/constraints.txt
  # SALib (rodfem sensitivity) needs pandas, SciPy and matplotlib: Debian's, built for its NumPy,
  # pinned so that pip takes the SALib that fits them (1.4.8 on Debian 12; SALib 1.5 asks for
  # pandas 2, which pip would otherwise install over Debian's) and installs none of the three.
  /usr/bin/python3 -c 'import importlib.metadata as m
for name in ("pandas", "scipy", "matplotlib"):
    print(f"{name}=={m.version(name)}")' >> .venv/constraints.txt
  # pip weighs only what it installs, not the Debian packages the venv sees, and reports (in red)
  # any of theirs it breaks: pyvista's cyclopts needs a newer rich than Debian 12's, whose newest
  # markdown-it-py (4) Debian 12's MyST and mdit-py-plugins refuse (<3). So every version bound
  # of an installed Debian package is a constraint too: pip then takes a markdown-it-py that both
  # accept (2.2 on Debian 12; on Debian 13 its own 3.0, which its MyST 4 asks for, is kept).
  # Should they leave pip no choice, it installs without them (and says what it breaks).
  # (-I: the interpreter alone, without the current directory and so without rodfem's egg-info.)
  /usr/bin/python3 -I -c 'import importlib.metadata as m
from packaging.requirements import InvalidRequirement, Requirement
bounds = set()
for dist in m.distributions():
    for text in dist.requires or ():
        try:
            req = Requirement(text)
        except InvalidRequirement:
            continue
        if req.specifier and (req.marker is None or req.marker.evaluate({"extra": ""})):
            bounds.add(f"{req.name}{req.specifier}")
print("\n".join(sorted(bounds)))' > .venv/debian-bounds.txt
  if [ "$extras" != test ]; then
    # The same for Sphinx, MyST and docutils: Debian's own, which its Furo theme and MathJax fit.
    # Unpinned, jupytext's requirements let pip replace them with PyPI's newest, a Sphinx that
    # Debian 12's Furo does not know. (Debian's furo says it is version 0.0.0: not pinned.)
    /usr/bin/python3 -c 'import importlib.metadata as m
for name in ("sphinx", "myst-parser", "docutils", "mdit-py-plugins"):
    print(f"{name}=={m.version(name)}")' >> .venv/constraints.txt
  fi
  pip=(.venv/bin/python -m pip install -q --disable-pip-version-check -c .venv/constraints.txt)
  if "${pip[@]}" -c .venv/debian-bounds.txt "$numpy_pin" -e ".[$extras]" 2>.venv/pip.log; then
    cat .venv/pip.log >&2  # whatever pip had to say
  else
    echo "setup: pip cannot also meet every Debian package's version bounds" \
      "(.venv/pip.log); installing without them"
    "${pip[@]}" "$numpy_pin" -e ".[$extras]"
  fi
  touch "$stamp"
fi

# What a first run would compile, compiled now: the time loops, and each built-in scene's forms
# and operators, into the per-user caches (a second `make setup` finds them there: a few seconds).
# The docs' set-up leaves it to the plain one.
# Python's bytecode too: where PYTHONDONTWRITEBYTECODE is set (as on some managed machines), every
# run would compile rodfem's hundred modules again, 70-80 ms of a small run's start.
if [ "$extras" = test ]; then
  .venv/bin/python -m compileall -q rodfem forms
  .venv/bin/python -m rodfem prepare --quiet
fi
