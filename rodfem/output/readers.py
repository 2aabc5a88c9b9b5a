"""A run directory's data read back with h5py and NumPy alone (no VTK, no dolfinx): the history
(``history.h5``, or the ``history.csv`` of an earlier rodfem) and the fields (``fields.xdmf``).
``rodfem.load``, ``rodfem.read_fields`` and the figures read through here.

``fields.xdmf``: rodfem writes XDMF 3 the way dolfinx does (a mesh grid, then per field a temporal
collection of grids that include the mesh by reference and carry one attribute each), with the
heavy data in HDF5: its own runs as rows (hyperslabs) of the segments in ``fields/``, dolfinx's
files as one dataset per step in ``fields.h5``. This reader reads both with h5py and the standard
library's XML parser. (Stock meshio 5 cannot: it does not know the topology name "PolyLine",
which the XDMF specification and dolfinx use for interval meshes, and it reads a single
collection per file.) h5py is imported where a file is read: imported before dolfinx, Debian's
serial h5py aborts a run under mpirun.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from rodfem.output.columns import NAMES as HISTORY_COLUMNS

HISTORY = "history.h5"  # the history of a run (rodfem.output.files.HistoryFile)
DATASET = "history"  # its dataset: steps × columns, float64; attribute "columns": the names
LEGACY_HISTORY = "history.csv"  # what an earlier rodfem wrote instead


class PlotError(ValueError):
    """``rodfem plot`` cannot draw its figures, or a run cannot be read (exit code 2)."""


class RunDirectoryError(PlotError):
    """A path given to ``rodfem plot`` or ``rodfem.load`` is not a complete rodfem run
    directory."""


class History:
    """The columns of a run's history (:mod:`rodfem.output.columns`) by name, one entry per kept
    step: ``history.u_1`` or ``history["u_1"]``; ``rows``: the whole table (steps × columns)."""

    def __init__(self, rows: np.ndarray, names: tuple[str, ...] = HISTORY_COLUMNS):
        self.names, self.rows = tuple(names), rows
        self._columns = {name: rows[:, i] for i, name in enumerate(self.names)}

    def __len__(self) -> int:
        return len(self.rows)

    def __getitem__(self, name: str) -> np.ndarray:
        return self._columns[name]

    def __getattr__(self, name: str) -> np.ndarray:
        try:
            return self.__dict__["_columns"][name]
        except KeyError:
            raise AttributeError(name) from None


def history_path(run: Path) -> Path:
    """The history file of a run directory: history.h5, or an earlier rodfem's history.csv."""
    run = Path(run)
    return run / LEGACY_HISTORY if not (run / HISTORY).exists() and (
        run / LEGACY_HISTORY).exists() else run / HISTORY


def _header(path: Path, header: tuple[str, ...]) -> None:
    if header[:len(HISTORY_COLUMNS)] != HISTORY_COLUMNS or len(set(header)) != len(header):
        raise RunDirectoryError(f"{path} is not a rodfem history (its columns do not begin "
                                f"{','.join(HISTORY_COLUMNS)})")


def _read_h5(path: Path) -> tuple[tuple[str, ...], np.ndarray]:
    import h5py  # here: imported before dolfinx, Debian's serial h5py aborts an MPI run

    with h5py.File(path, "r") as file:
        data = file.get(DATASET)
        names = data.attrs.get("columns") if isinstance(data, h5py.Dataset) else None
        if not isinstance(names, str):
            raise RunDirectoryError(f"{path} is not a rodfem history (no dataset /{DATASET} "
                                    "with its columns)")
        header = tuple(names.split(","))
        _header(path, header)
        if data.ndim != 2 or data.shape[1] != len(header) or data.dtype != np.float64:
            raise RunDirectoryError(f"{path}: /{DATASET} is not steps × {len(header)} float64")
        return header, data[()]


def _read_csv(path: Path) -> tuple[tuple[str, ...], np.ndarray]:
    with open(path, encoding="utf-8") as file:
        header = tuple(file.readline().strip().split(","))
        _header(path, header)
        lines = file.read().split()
    rows = np.loadtxt(lines, delimiter=",", ndmin=2) if lines else np.zeros((0, len(header)))
    if rows.shape[1] != len(header):
        raise RunDirectoryError(f"{path} has rows of {rows.shape[1]} values, not {len(header)}")
    return header, rows


def read_history(path: Path, empty: bool = False) -> History:
    """Read a run's history (``history.h5``, or an earlier rodfem's ``history.csv``), columns by
    the names the file itself holds; :class:`RunDirectoryError` (one line) unless it is rodfem's:
    the default columns first, then any the scene chose (distinct names). ``empty``: a history
    without steps is read, not refused."""
    path = Path(path)
    try:
        header, rows = (_read_csv if path.suffix == ".csv" else _read_h5)(path)
    except RunDirectoryError:
        raise
    except (OSError, ValueError, KeyError, TypeError, UnicodeDecodeError) as err:
        reason = " ".join(str(err).split(";")[0].split())  # one line, without NumPy's advice
        raise RunDirectoryError(f"cannot read {path}: {reason}") from None
    if not len(rows) and not empty:
        raise RunDirectoryError(f"{path} holds no steps")
    return History(rows, header)


NODE_FUNCTIONS = ("theta", "u", "velocity")
CELL_FUNCTIONS = ("sigma", "heat_flux")
FUNCTIONS = (*NODE_FUNCTIONS, *CELL_FUNCTIONS)
MEANINGS = {"theta": "temperature θ (physical)", "u": "displacement u",
            "velocity": "velocity u_t", "sigma": "stress σ = u_x + ζ u_xt − aθ, on each cell",
            "heat_flux": "heat flux −θ_x, on each cell"}


class FieldsError(ValueError):
    """``fields.xdmf`` is missing, unreadable or not what rodfem writes."""


@dataclass(frozen=True)
class Fields:
    """The saved fields of a run, on nodes and cells sorted by x; a field the run did not save
    (``output.fields``) is None.

    Attributes:
        x: node coordinates, increasing, shape (nodes,).
        t: saved times, increasing, shape (saves,).
        x_cells: cell midpoints, increasing, shape (cells,); cell j spans x[j] .. x[j + 1].
        theta: physical temperature θ at the nodes, shape (saves, nodes).
        u: displacement u at the nodes, shape (saves, nodes).
        velocity: velocity u_t at the nodes, shape (saves, nodes).
        sigma: stress σ = u_x + ζ u_xt − aθ, constant per cell, shape (saves, cells).
        heat_flux: heat flux −θ_x, constant per cell, shape (saves, cells).
        attrs: what names the run (its scene), for :meth:`to_xarray`; empty for fields read
            alone (:func:`read_fields`).
    """

    x: np.ndarray
    t: np.ndarray
    x_cells: np.ndarray
    theta: np.ndarray | None = None
    u: np.ndarray | None = None
    sigma: np.ndarray | None = None
    velocity: np.ndarray | None = None
    heat_flux: np.ndarray | None = None
    attrs: dict[str, str] = field(default_factory=dict, compare=False)

    @property
    def names(self) -> tuple[str, ...]:
        """The fields saved, in the order of :data:`FUNCTIONS`."""
        return tuple(name for name in FUNCTIONS if getattr(self, name) is not None)

    def to_xarray(self):
        """The fields as an ``xarray.Dataset``: a variable per saved field on dims (t, x), the
        nodes, or (t, x_cells), the cells (σ and the heat flux, constant on each); the
        coordinates t, x, x_cells; the scene in its attributes (``scene``, ``description``,
        ``scene_toml``). The values are these arrays, unchanged. Needs xarray."""
        from rodfem.output.frames import fields_dataset

        return fields_dataset(self, MEANINGS, NODE_FUNCTIONS)

    def __repr__(self) -> str:
        from rodfem.output.frames import number

        saves = len(self.t)
        times = f"t = {number(self.t[0])} … {number(self.t[-1])}" if saves else "no save"
        lines = [f"<rodfem.Fields{' of ' + self.attrs['scene'] if self.attrs.get('scene') else ''}"
                 f": {saves} saves, {times}; {len(self.x)} nodes on [{number(self.x[0])}, "
                 f"{number(self.x[-1])}]>"]
        for where, kind, size in (("nodes", NODE_FUNCTIONS, len(self.x)),
                                  ("cells", CELL_FUNCTIONS, len(self.x_cells))):
            names = [name for name in self.names if name in kind]
            if names:
                lines.append(f"    {', '.join(names)}: ({saves}, {size}) on the {where}")
        return "\n".join(lines)


class _Reader:
    """The data items of one XDMF file, HDF5 files opened once each."""

    def __init__(self, path: Path):
        self.path, self.files, self.arrays = path, {}, {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        for f in self.files.values():
            f.close()

    def _hdf(self, text: str, index=()) -> np.ndarray:
        name, _, dataset = text.strip().partition(":")
        file = Path(name)
        if file.is_absolute() or ".." in file.parts or not dataset:
            raise FieldsError(f"a data item names {text.strip()!r}, not a file beside it")
        import h5py

        if name not in self.files:
            self.files[name] = h5py.File(self.path.parent / file, "r")
        if (name, dataset) not in self.arrays:  # read once: the steps are rows of a few datasets
            data = self.files[name][dataset]
            if not isinstance(data, h5py.Dataset):
                raise FieldsError(f"{text.strip()} is not a dataset")
            self.arrays[name, dataset] = data[()]
        data = self.arrays[name, dataset]
        if index and data.ndim != len(index):
            raise FieldsError("a hyperslab does not match its data")
        return data[index]

    def data(self, item) -> np.ndarray:
        """The array of a DataItem: HDF, XML or a hyperslab of one."""
        if item is None or item.tag != "DataItem":
            raise FieldsError("a data item is missing")
        if item.get("ItemType") == "HyperSlab":
            selection, source = list(item)
            start, stride, count = self.data(selection).astype(int).reshape(3, -1)
            if source.tag != "DataItem" or source.get("Format") != "HDF" or (
                    start < 0).any() or (stride < 1).any():
                raise FieldsError("a hyperslab that is not of an HDF5 dataset")
            index = tuple(slice(a, a + s * c, s)
                          for a, s, c in zip(start, stride, count, strict=True))
            part = self._hdf(source.text or "", index)
            if part.shape != tuple(count):
                raise FieldsError("a hyperslab reaches past its data")
            return part
        if item.get("Format") == "XML":
            return np.array(item.text.split(), dtype=float)
        if item.get("Format") == "HDF":
            return self._hdf(item.text or "")
        raise FieldsError(f"a data item of format {item.get('Format')!r}")

    def read(self):
        root = ElementTree.parse(self.path).getroot()
        domain = root.find("Domain")
        if domain is None:
            raise FieldsError("no Domain")
        mesh = next((g for g in domain.findall("Grid") if g.get("GridType") == "Uniform"), None)
        if mesh is None:
            raise FieldsError("no mesh")
        points = self.data(mesh.find("Geometry/DataItem"))
        cells = self.data(mesh.find("Topology/DataItem"))
        series = {}
        for name in FUNCTIONS:
            grids = [g for g in domain.findall("Grid")
                     if g.get("CollectionType") == "Temporal" and g.get("Name") == name]
            if not grids:
                continue  # not saved
            if len(grids) != 1:
                raise FieldsError(f"two time series '{name}'")
            times, values = [], []
            for grid in grids[0].findall("Grid"):
                time = grid.find("Time")
                if time is None:
                    raise FieldsError(f"a step of '{name}' has no time")
                times.append(float(time.get("Value")))
                values.append(np.asarray(self.data(grid.find("Attribute/DataItem")),
                                         dtype=float).reshape(-1))
            series[name] = (np.array(times), values)
        return points, cells, series


def read_fields(path: str | Path) -> Fields:
    """Read the fields of a run's ``fields.xdmf`` (and the HDF5 files it names).

    Args:
        path: the XDMF file.

    Returns:
        The fields at every saved step, nodes and cells sorted by x, steps by time.

    Raises:
        FieldsError: the file is missing, unreadable, or its functions do not share their times.
    """
    path = Path(path)
    try:
        with _Reader(path) as reader:
            points, cells, series = reader.read()
    except FieldsError as err:
        raise FieldsError(f"{path}: {err}") from None
    except (OSError, KeyError, ValueError, TypeError, IndexError, ElementTree.ParseError) as err:
        raise FieldsError(f"{path} is not readable as rodfem fields ({err})") from None

    if not series:
        raise FieldsError(f"{path} holds none of the fields {', '.join(FUNCTIONS)}")
    times = next(iter(series.values()))[0]
    if times.size == 0:
        raise FieldsError(f"{path} holds no saved step")
    if any(not np.array_equal(s[0], times) for s in series.values()):
        raise FieldsError(f"{path}: its fields are saved at different times")
    if points.ndim != 2 or cells.ndim != 2 or cells.shape[1] != 2 or cells.size == 0:
        raise FieldsError(f"{path}: not an interval mesh")
    if cells.min() < 0 or cells.max() >= len(points):
        raise FieldsError(f"{path}: the mesh's cells name nodes it does not have")
    for name, (_, values) in series.items():
        size = len(points) if name in NODE_FUNCTIONS else len(cells)
        if {len(v) for v in values} != {size}:
            raise FieldsError(f"{path}: the fields do not match the mesh's nodes and cells")

    x = points[:, 0]
    nodes = np.argsort(x, kind="stable")
    midpoints = x[cells.astype(np.int64)].mean(axis=1)
    order = np.argsort(midpoints, kind="stable")
    steps = np.argsort(times, kind="stable")
    return Fields(
        x=x[nodes],
        t=times[steps],
        x_cells=midpoints[order],
        **{name: np.array(values)[np.ix_(steps, nodes if name in NODE_FUNCTIONS else order)]
           for name, (_, values) in series.items()},
    )
