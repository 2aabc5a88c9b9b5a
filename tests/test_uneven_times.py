"""Histories and fields at uneven times (an adaptive run's: steps of any length, two rows as close
as 1e-10, rows at contact events): what reads them takes the times from the ``t`` column and the
fields' times, never as n·Δt. The run directories are written by rodfem's own writers
(:class:`rodfem.output.files.HistoryFile`, :class:`rodfem.output.fields.FieldFile`), so the files
are real; fixed-step histories keep their measures bit for bit.
"""

import json

import numpy as np
import pytest
from PIL import Image, ImageSequence

import rodfem
import rodfem.scene
from conftest import COMM
from rodfem.output.measures import Contact, in_contact, measures

GAP = 0.1


def _history(t: np.ndarray, sigma: np.ndarray, event: np.ndarray | None = None) -> dict:
    u_1 = GAP - 0.01 * sigma
    history = {"t": t, "u_1": u_1, "u_half": 0.5 * u_1, "ut_1": np.gradient(u_1, t),
               "sigma_1": sigma, "energy": 1.0 + 0.0 * t, "iterations": np.ones_like(t)}
    if event is not None:
        history.update(dt=np.diff(t, prepend=t[0]), event=event)
    return history


class _Scene(dict):
    """The keys the measures read."""


SCENE = _Scene({"obstacle.gap": GAP, "time.dt": 0.25})
SUMMARY = {"iterations_max": 1, "loop_seconds": 0.0}


def test_measures_of_uneven_steps_are_their_hand_values():
    # Steps of 0.5, 0.25, 1e-10, 1.25 − 1e-10, 1, 2 (t = 0, .5, .75, .75 + 1e-10, 2, 3, 5); the
    # rod touches at rows 2 and 4; row 3 is an event (contact ends there, σ(1) = +0 there).
    t = np.array([0.0, 0.5, 0.75, 0.75 + 1e-10, 2.0, 3.0, 5.0])
    sigma = np.array([0.0, 0.0, -1.0, 0.0, -2.0, 0.0, 0.0])
    event = np.array([0, 0, 0, 1, 0, 0, 0])
    history = _history(t, sigma, event)
    # Steps 1 … 6 in contact: no, yes, yes (ends at the event: its start's state), yes, no, no.
    assert in_contact(history).tolist() == [False, True, True, True, False, False]
    values = measures(history, SCENE, SUMMARY)
    assert values["contact_fraction"] == pytest.approx((0.25 + 1e-10 + 1.25 - 1e-10) / 5.0,
                                                       rel=1e-15)
    assert values["contact_intervals"] == 1
    assert values["last_contact_change"] == 3.0  # contact ended in the step ending at t = 3
    assert values["t_final"] == 5.0
    # An event that begins contact: the change is at the event's time.
    sigma2 = np.array([0.0, 0.0, -0.0, -1.0, -1.0, 0.0, 0.0])
    event2 = np.array([0, 0, 1, 0, 0, 1, 0])
    values2 = measures(_history(t, sigma2, event2), SCENE, SUMMARY)
    assert values2["last_contact_change"] == 3.0  # the event that ended it, at t = 3
    assert values2["contact_fraction"] == pytest.approx((1e-10 + 1.25 - 1e-10 + 1.0) / 5.0,
                                                        rel=1e-15)
    assert values2["contact_intervals"] == 1


@pytest.mark.parametrize("blocks", [(7,), (1, 1, 1, 1, 1, 1, 1), (3, 4), (2, 5)])
def test_the_running_record_is_the_histories_whatever_its_blocks(blocks):
    t = np.array([0.0, 0.5, 0.75, 0.75 + 1e-10, 2.0, 3.0, 5.0])
    sigma = np.array([-1.0, 0.0, -1.0, 0.0, -2.0, 0.0, -1e-16])
    event = np.array([0, 1, 0, 1, 0, 1, 0])
    history = _history(t, sigma, event)
    kept, start = Contact(), 0
    for size in blocks:
        rows = slice(start, start + size)
        kept.update(np.arange(7)[rows], history["u_1"][rows], sigma[rows], GAP, t[rows],
                    event[rows])
        start += size
    from_rows = measures(history, SCENE, SUMMARY)
    from_record = measures(history, SCENE, {**SUMMARY, "contact": vars(kept)})
    for name in ("contact_fraction", "contact_intervals", "last_contact_change"):
        assert from_record[name] == pytest.approx(from_rows[name], rel=1e-15), name
    assert kept.time == 5.0


def test_fixed_step_measures_count_steps_bit_for_bit():
    """Without events (a fixed-step run) the measures are those of counting steps, and a record
    kept with the rows' times gives the change at tⁿ = nΔt, the same bits as n · Δt."""
    dt, n = SCENE["time.dt"], np.arange(41)
    t = n * dt
    sigma = np.where(np.sin(0.7 * t) > 0.3, -1.0, 0.0)
    history = _history(t, sigma)
    touching = sigma[1:] < 0.0
    changed = np.flatnonzero(np.diff(touching.astype(np.int8), prepend=0) != 0)
    values = measures(history, SCENE, SUMMARY)
    assert values["contact_fraction"] == float(touching.mean())
    assert values["last_contact_change"] == float(t[1:][changed[-1]])
    timed, counted = Contact(), Contact()
    for rows in (slice(0, 17), slice(17, 41)):
        timed.update(n[rows], history["u_1"][rows], sigma[rows], GAP, t[rows])
        counted.update(n[rows], history["u_1"][rows], sigma[rows], GAP)
    for kept in (timed, counted):
        kept_values = measures(history, SCENE, {**SUMMARY, "contact": vars(kept)})
        assert kept_values["contact_fraction"] == counted.touching / counted.steps
        assert kept_values["last_contact_change"] == counted.last_change * dt
        assert kept_values["contact_intervals"] == values["contact_intervals"]


def _uneven_times() -> np.ndarray:
    """0 … 0.6 in steps from 1e-10 to 0.03: crowded at 0.2 (two rows 1e-10 apart) and at 0.4."""
    coarse = np.arange(0.0, 0.6 + 1e-12, 0.03)
    fine = np.concatenate([0.2 + np.geomspace(1e-10, 0.02, 12), 0.4 + np.linspace(0, 1e-3, 6)])
    t = np.unique(np.concatenate([coarse, fine, [0.2]]))
    assert np.min(np.diff(t)) <= 1.5e-10 and np.all(np.diff(t) > 0)
    return t


def _uneven_run(out, event_columns: bool):
    """A run directory of paper1's scene on 20 cells whose history and fields are at uneven
    times, written by rodfem's writers; returns the times and the scene."""
    from rodfem.discrete.discretisation import Discretisation
    from rodfem.output.columns import Column, for_scene
    from rodfem.output.directories import finish, prepare_directory
    from rodfem.output.fields import FieldFile
    from rodfem.output.files import HistoryFile, write_json, write_text

    scene = rodfem.scene.load("paper1", ["mesh.cells=20", "time.end=0.6"])
    t = _uneven_times()
    prepare_directory(out, False, COMM)
    write_text(out / "scene.toml", scene.to_toml(), COMM)
    columns = for_scene(scene)
    sigma = np.where((t > 0.2) & (t < 0.4), -np.sin(np.pi * (t - 0.2) / 0.2), 0.0)
    history = _history(t, sigma, np.isin(t, [0.2, 0.4]).astype(float) if event_columns
                       else None)
    if event_columns:  # what an adaptive run adds
        columns = (*columns, Column("dt", "", lambda raw, c: raw["n"]),
                   Column("event", "", lambda raw, c: raw["n"], integer=True))
    rows = np.column_stack([history[c.name] for c in columns])
    file = HistoryFile(out / "history.h5", COMM, columns)
    file.append(rows)
    file.checkpoint()
    fields = FieldFile(out / "fields.xdmf", Discretisation(scene, COMM))
    x = fields.x
    for n, time in enumerate(t):  # a wave along the rod: [Θ; D; U]
        u = 0.1 * np.sin(np.pi * x) * np.sin(2 * np.pi * time / 0.6)
        fields.write(n, float(time), np.concatenate([np.cos(np.pi * x) * time, 1e-3 * u, u]))
    fields.checkpoint()
    write_json(out / "summary.json", {"status": "complete", "steps": int(t.size - 1)}, COMM)
    finish(out, "complete", COMM)
    COMM.barrier()
    return t, scene


def test_plot_draws_a_run_at_uneven_times(shared_dir):
    from rodfem.cli import main
    from rodfem.post.animation import frame_durations, frame_indices

    out = shared_dir / "uneven"
    t, _ = _uneven_run(out, event_columns=True)
    assert main(["plot", str(out)]) == 0
    if COMM.rank != 0:
        return
    from rodfem.output.readers import read_fields, read_history

    assert np.array_equal(read_history(out / "history.h5").t, t)
    assert np.array_equal(read_fields(out / "fields.xdmf").t, t)
    made = sorted(p.name for p in (out / "figures").iterdir())
    assert made == ["contact.png", "energy.png", "rod.gif", "spacetime_sigma.png",
                    "spacetime_theta.png", "spacetime_u.png"]
    for name in made:
        assert (out / "figures" / name).stat().st_size > 10_000, name
    frames = frame_indices(t)
    with Image.open(out / "figures/rod.gif") as gif:
        shown = [frame.info["duration"] for frame in ImageSequence.Iterator(gif)]
    # Evenly spaced in time: the crowded saves at 0.2 and 0.4 give one frame or two, not 18.
    assert len(frames) == len(shown) < 30
    assert np.max(np.diff(t[frames])) < 0.04
    durations = frame_durations(t, frames)
    assert shown == durations and max(durations) > 2 * min(durations)


def test_frames_of_even_saves_are_every_kth():
    from rodfem.post.animation import frame_durations, frame_indices

    for count in (1, 2, 59, 60, 61, 161, 1001):
        t = np.arange(count) * 0.003125
        stride = -(-count // 60)
        expected = np.arange(0, count, stride)
        if expected[-1] != count - 1:
            expected = np.append(expected[:59], count - 1)
        assert np.array_equal(frame_indices(t), expected)
        assert np.array_equal(frame_indices(count), expected)
        assert isinstance(frame_durations(t, expected), int)


def test_load_returns_the_times_as_written(shared_dir):
    out = shared_dir / "uneven-load"
    t, scene = _uneven_run(out, event_columns=False)
    result = rodfem.load(out)
    assert np.array_equal(result.history["t"], t)
    assert np.array_equal(result.fields.t, t)
    kept = json.loads((out / "summary.json").read_text())
    assert kept["steps"] == t.size - 1
    assert result.measures["t_final"] == t[-1]


def test_the_impacts_l1_error_weighs_each_step_by_its_length():
    """GetFEM's measure Σ Δtⁿ |Uⁿ(1) − u(1, tⁿ)| of the impact benchmark over uneven steps, and a
    fixed-step history's Δt · Σ as before."""
    from rodfem.model import impact

    t = np.array([0.0, 0.5, 1.0, 1.0 + 1e-10, 1.5, 3.0])
    error = np.array([0.0, 1.0, -2.0, 4.0, 0.5, 0.25])
    history = {"t": t, "u_1": impact.end_displacement(t) + error, "dt": np.diff(t, prepend=0.0),
               "sigma_1": impact.end_stress(t), "energy": np.full(t.size, impact.ENERGY)}
    expected = 0.5 * 1.0 + 0.5 * 2.0 + 1e-10 * 4.0 + (0.5 - 1e-10) * 0.5 + 1.5 * 0.25
    assert impact.errors(history)["u1_l1"] == pytest.approx(expected, rel=1e-14)
    even = np.arange(7) * 0.5
    fixed = {**history, "t": even, "u_1": impact.end_displacement(even) + np.arange(7.0)}
    del fixed["dt"]
    assert impact.errors(fixed)["u1_l1"] == 0.5 * np.sum(np.arange(1.0, 7.0))


def test_fields_of_a_step_of_another_length():
    """σ (whose ζ u_xt is ζ D_x/Δt) and the velocity D/Δt of a state whose D is over a step of
    another length: those of a scene with that step; the scene's own step, bit for bit."""
    from rodfem.discrete.discretisation import Discretisation
    from rodfem.output.pointwise import Pointwise

    base = ["mesh.cells=20", "model.zeta=0.7"]
    made = Pointwise(Discretisation(rodfem.scene.load("paper1", [*base, "time.dt=0.001"]), COMM))
    other = Pointwise(Discretisation(rodfem.scene.load("paper1", [*base, "time.dt=0.00025"]),
                                     COMM))
    s = np.random.default_rng(3).standard_normal(3 * made.n)
    for name in ("sigma", "velocity", "heat_flux", "theta", "u"):
        scaled, direct = made.field(name, s, 0.00025), other.field(name, s)
        scale = np.max(np.abs(direct))
        assert np.max(np.abs(scaled - direct)) <= 1e-14 * scale, name
        assert made.field(name, s, 0.001).tobytes() == made.field(name, s).tobytes()


def test_contact_shading_reaches_the_events():
    from rodfem.output.readers import History
    from rodfem.post.curves import _contact_intervals

    t = np.array([0.0, 0.1, 0.2, 0.2 + 1e-10, 0.3, 0.4, 0.5])
    u_1 = np.array([0.0, 0.05, GAP, 0.2, 0.3, GAP, 0.0])  # events at rows 2 and 5
    rows = np.column_stack([t, u_1, np.array([0, 0, 1, 0, 0, 1, 0.0])])

    class Run:
        gap, history = GAP, History(rows, ("t", "u_1", "event"))

    assert _contact_intervals(Run) == [(0.2, 0.4)]
    Run.history = History(rows[:, :2], ("t", "u_1"))  # without events: the rows with u(1) > g
    assert _contact_intervals(Run) == [(0.2 + 1e-10, 0.3)]


def test_errors_in_time_of_uneven_steps_against_a_fine_run():
    """An adaptive run's u(1, ·) against a fine fixed-step one: the reference at its own times
    where they are the fine run's, interpolated between them elsewhere; its norms weigh each
    step by its length."""
    from rodfem.studies.verification import convergence as cv

    t_fine = np.arange(9) * 0.125
    y_fine = t_fine ** 2
    t = np.array([0.0, 0.25, 0.3, 0.3 + 1e-10, 1.0])
    error = np.array([0.0, 0.5, -1.0, 2.0, 0.25])
    reference = np.interp(t, t_fine, y_fine)
    assert cv.reference_at(t, t_fine, y_fine)[[0, 1, 4]].tolist() == [0.0, 0.0625, 1.0]
    e_max, e_l1, e_l2 = cv.time_errors(t, reference + error, t_fine, y_fine)
    steps = np.diff(t)
    assert e_max == 2.0
    assert e_l1 == pytest.approx(np.sum(steps * np.abs(error[1:])), rel=1e-15)
    assert e_l2 == pytest.approx(np.sqrt(np.sum(steps * error[1:] ** 2)), rel=1e-15)
    with pytest.raises(ValueError, match="outside the fine run's"):
        cv.time_errors(t, t, t_fine[:5], y_fine[:5])
    assert not cv.uneven(np.arange(8001) * 0.001) and cv.uneven(t)


def test_spacetime_maps_place_each_save_at_its_time(shared_dir):
    from rodfem.output.readers import read_fields
    from rodfem.post.spacetime import _grid

    out = shared_dir / "uneven-map"
    t, _ = _uneven_run(out, event_columns=False)
    if COMM.rank != 0:
        return
    fields = read_fields(out / "fields.xdmf")
    nodes = _grid(fields, "u", 0.0, 1.0)
    assert np.array_equal(nodes.x, t)  # a column of points at each saved time
    cells = _grid(fields, "sigma", 0.0, 1.0)  # each save's cells reach halfway to its neighbours
    assert np.array_equal(cells.x, np.concatenate([[t[0]], (t[1:] + t[:-1]) / 2, [t[-1]]]))
