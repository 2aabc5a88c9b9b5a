"""``fields.xdmf`` read back through meshio: θ and u per node, σ per cell, at the saved steps.

dolfinx writes one XDMF file with the mesh grid and, per function, a temporal collection of grids
that include the mesh by reference and carry one attribute each; the heavy data is in
``fields.h5``, which meshio opens with h5py.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import ParseError

import numpy as np
from meshio import ReadError
from meshio.xdmf import common as xdmf_common
from meshio.xdmf.time_series import TimeSeriesReader

# dolfinx names an interval mesh's topology "PolyLine", as the XDMF specification spells it;
# meshio 5.0 knows only the spelling "Polyline". Register dolfinx's spelling as an alias of the
# same meshio cell type, in the table meshio's readers look names up in.
xdmf_common.xdmf_to_meshio_type.setdefault("PolyLine", xdmf_common.xdmf_to_meshio_type["Polyline"])

FUNCTIONS = ("theta", "u", "sigma")


class FieldsError(ValueError):
    """``fields.xdmf`` is missing, unreadable or not what rodfem writes."""


@dataclass(frozen=True)
class Fields:
    """The saved fields of a run, on nodes and cells sorted by x.

    Attributes:
        x: node coordinates, increasing, shape (nodes,).
        t: saved times, increasing, shape (saves,).
        theta: physical temperature θ at the nodes, shape (saves, nodes).
        u: displacement u at the nodes, shape (saves, nodes).
        x_cells: cell midpoints, increasing, shape (cells,); cell j spans x[j] .. x[j + 1].
        sigma: stress σ = u_x + ζ u_xt − aθ, constant per cell, shape (saves, cells).
    """

    x: np.ndarray
    t: np.ndarray
    theta: np.ndarray
    u: np.ndarray
    x_cells: np.ndarray
    sigma: np.ndarray


class _FunctionSeries(TimeSeriesReader):
    """meshio's XDMF time-series reader, for dolfinx's one collection per function (meshio's own
    reader picks a single collection: the last one in the file)."""

    def series(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Times and values (point data per node, or cell data per cell) of one function."""
        grids = [g for g in self.domain
                 if g.get("CollectionType") == "Temporal" and g.get("Name") == name]
        if len(grids) != 1:
            raise FieldsError(f"no time series '{name}'")
        self.collection = list(grids[0])  # read_data(k) reads the k-th grid of self.collection
        times, values = [], []
        for k in range(len(self.collection)):
            t, point_data, cell_data = self.read_data(k)
            data = point_data[name] if name in point_data else cell_data[name][0]
            times.append(t)
            values.append(np.asarray(data, dtype=float).reshape(len(data)))
        return np.array(times), np.array(values)


def read_fields(path: Path) -> Fields:
    """Read θ, u and σ from a run's ``fields.xdmf`` (and the ``fields.h5`` beside it).

    Args:
        path: the XDMF file.

    Returns:
        The fields at every saved step, nodes and cells sorted by x, steps by time.

    Raises:
        FieldsError: the file is missing, unreadable, or its functions do not share their times.
    """
    try:
        with _FunctionSeries(path) as reader:
            points, cells = reader.read_points_cells()
            series = {name: reader.series(name) for name in FUNCTIONS}
    except FieldsError as err:
        raise FieldsError(f"{path}: {err}") from None
    except (OSError, KeyError, ValueError, ParseError, ReadError) as err:
        raise FieldsError(f"{path} is not readable as rodfem fields ({err})") from None

    times = series["theta"][0]
    if times.size == 0:
        raise FieldsError(f"{path} holds no saved step")
    if any(not np.array_equal(series[name][0], times) for name in FUNCTIONS):
        raise FieldsError(f"{path}: θ, u and σ are saved at different times")
    if len(cells) != 1 or cells[0].data.shape[1] != 2:
        raise FieldsError(f"{path}: not an interval mesh")

    x = points[:, 0]
    nodes = np.argsort(x, kind="stable")
    midpoints = x[cells[0].data].mean(axis=1)
    order = np.argsort(midpoints, kind="stable")
    steps = np.argsort(times, kind="stable")
    return Fields(
        x=x[nodes],
        t=times[steps],
        theta=series["theta"][1][np.ix_(steps, nodes)],
        u=series["u"][1][np.ix_(steps, nodes)],
        x_cells=midpoints[order],
        sigma=series["sigma"][1][np.ix_(steps, order)],
    )
