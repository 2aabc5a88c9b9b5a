"""Every mistake in a scene gets exit code 2, one line naming the key and what is allowed, and no
output directory; nothing runs before the whole scene is valid."""

import os
import signal
from pathlib import Path

import pytest
from mpi4py import MPI

import rodfem
from conftest import COMM, history_rows
from rodfem.cli import main
from rodfem.scene import SceneError

CASES = [
    # (--set overrides, expected fragment of the message)
    (["model.a=\"x\""], "model.a: must be a number"),
    (["model.zeta=nan"], "model.zeta: must be finite"),
    (["time.dt=inf"], "time.dt: must be finite"),
    (["model.a=-0.1"], "model.a: must be >= 0"),
    (["model.b=-1"], "model.b: must be >= 0"),
    (["model.zeta=-0.2"], "model.zeta: must be >= 0"),
    (["model.k=-1"], "model.k: must be >= 0"),
    (["obstacle.epsilon=0"], "obstacle.epsilon: must be >= 1e-12"),
    (["obstacle.epsilon=-0.01"], "obstacle.epsilon: must be >= 1e-12"),
    (["mesh.cells=1"], "mesh.cells: must be >= 2"),
    (["mesh.cells=2.5"], "mesh.cells: must be an integer"),
    (["mesh.cells=true"], "mesh.cells: must be an integer"),
    (["time.dt=0"], "time.dt: must be >= 1e-12"),
    (["time.dt=-0.001"], "time.dt: must be >= 1e-12"),
    (["time.dt=1e-300", "time.end=1e-299"], "time.dt: must be >= 1e-12"),
    (["time.dt=1e-9"], "time.dt: at most 1e+08 steps"),
    (["model.a=1e308"], "model.a: must be <= 1e+12"),
    (["model.theta_A=-1e200"], "model.theta_A: must be >= -1e+12"),
    (["mesh.cells=3000000000"], "mesh.cells: must be <= 1e+07"),
    (["output.every=1" + "0" * 400], "output.every: must be <= 1e+08"),
    (["initial.u0=x*9" + "9" * 400], "has a number too large for a float"),
    (["initial.u0=" + "-" * 990 + "x*0"], "is nested more than 64 deep"),
    (["initial.u1=x # c"], "contains '#'"),
    (["time.dt=10"], "time.dt: must be <= time.end"),
    (["time.end=1.0005"], "time.end: must be a whole number of steps"),
    (["heat_exchange.k1=2"], 'heat_exchange.k1: applies only with heat_exchange.law = '
     '"pressure" or "gap", not "constant"'),
    (["heat_exchange.law=gap", "heat_exchange.exponent=2"], "heat_exchange.exponent: applies "
     'only with heat_exchange.law = "pressure", not "gap"'),
    (["heat_exchange.law=pressure", "heat_exchange.length=2"], "heat_exchange.length: applies "
     'only with heat_exchange.law = "gap", not "pressure"'),
    (["heat_exchange.law=pressure", "heat_exchange.k1=-1"], "heat_exchange.k1: must be >= 0"),
    (["heat_exchange.law=pressure", "heat_exchange.exponent=0"],
     "heat_exchange.exponent: must be > 0"),
    (["heat_exchange.law=gap", "heat_exchange.length=-0.1"], "heat_exchange.length: must be > 0"),
    (["heat_exchange.law=gap", "heat_exchange.k1=inf"], "heat_exchange.k1: must be finite"),
    (["obstacle.temperature=nan"], "obstacle.temperature: must be finite"),
    (["heat_exchange.law=radiation"], 'heat_exchange.law: must be one of "constant" | '
     '"pressure" | "gap"'),
    (["model.zetta=1"], "unknown key 'model.zetta': did you mean 'zeta'?"),
    (["obstacle.gapp=1"], "did you mean 'gap'?"),
    (["modle.zeta=1"], "unknown section 'modle': did you mean 'model'?"),
    (["measures.peak=1"], "--set measures.peak=1: measures are declared in a [measures] table of a "
     "scene or sweep file, not set by key"),
    (["initial.u1=20*x*(x-1"], "initial.u1: \"20*x*(x-1\" is not a valid expression"),
    (["initial.u1=y*x"], "initial.u1: \"y*x\" uses unknown name 'y'"),
    (["initial.theta0=__import__('os').getcwd()"], "initial.theta0:"),
    (["initial.u0=1 + x"], "initial.u0: must equal 0 at x = 0"),
    (["initial.u1=1"], "initial.u1: must equal 0 at x = 0"),
    (["initial.u0=true"], "initial.u0: true must be a string expression in x"),
    (["initial.u1=log(x)"], "initial.u1: not finite at x = 0"),
    (["discretisation.mass=lumpy"], 'discretisation.mass: must be one of "lumped" | '
     '"consistent" | "redistributed" | "redistributed-lumped" | "dispersion-free"'),
    (["discretisation.mass=dispersion-free"], 'discretisation.mass: "dispersion-free" is blended '
     'for time.scheme = "crank-nicolson", not "paper"'),
    (["discretisation.mass=dispersion-free", "time.scheme=crank-nicolson", "time.dt=0.008"],
     'discretisation.mass: "dispersion-free" needs time.dt <= h = 1/mesh.cells (beyond, its '
     "blend is not positive definite), got time.dt/h = 2"),
    (["discretisation.mass=dispersion-free", "time.scheme=crank-nicolson", "time.dt=0.004",
      "time.adaptive=true"], 'discretisation.mass: "dispersion-free" is blended for one ratio of '
     "time.dt to h, not for steps that adapt"),
    # adaptive steps
    (["time.tolerance=1e-4"],
     "time.tolerance: applies only with time.adaptive = true, not false"),
    (["time.dt_min=1e-6"], "time.dt_min: applies only with time.adaptive = true"),
    (["time.adaptive=true", "time.dt_min=0.01"],
     "time.dt: the first step must be >= time.dt_min = 0.01, got 0.001"),
    (["time.adaptive=true", "time.dt_min=0.002", "time.dt_max=0.0005"],
     "time.dt_max: must be 0 or >= time.dt_min = 0.002, got 0.0005"),
    (["time.adaptive=true", "time.dt_max=0.0005", "time.dt_min=0.0001"],
     "time.dt: the first step must be <= time.dt_max = 0.0005, got 0.001"),
    (["time.adaptive=1"], "time.adaptive: must be true or false, got 1"),
    (['time.adaptive="true"'], 'time.adaptive: must be true or false, got "true"'),
    (["time.adaptive=true", "time.tolerance=-1e-3"], "time.tolerance: must be >= 0"),
    (["solver.method=gauss"], "solver.method: must be one of \"direct\" | \"newton\" | \"picard\""),
    (["obstacle.kind=rigid"], "solver.method: \"picard\" cannot solve obstacle.kind = \"rigid\""),
    (["solver.tol=0"], "solver.tol: must be >= 1e-300"),
    (["solver.max_iterations=0"], "solver.max_iterations: must be >= 1"),
    (["output.every=-1"], "output.every: must be >= 0"),
    (["output.history_every=0"], "output.history_every: must be >= 1"),
    (["output.history_every=2.5"], "output.history_every: must be an integer"),
    (["model.zeta"], "--set model.zeta: must be section.key=value"),
    (["time.scheme=bdf2"], 'time.scheme: must be one of "paper" | "crank-nicolson"'),
    (["time.scheme=crank-nicolson", "model.b=0", "model.zeta=0", "solver.method=direct"],
     'time.scheme: "crank-nicolson" needs inertia or viscosity'),
    (["time.scheme=crank-nicolson", "obstacle.kind=rigid", "solver.method=direct"],
     'time.scheme: "crank-nicolson" models obstacle.kind = "rigid" only with '
     'discretisation.mass = "redistributed"'),
    (["discretisation.mass=redistributed", "time.scheme=crank-nicolson", "model.zeta=0"],
     'model.a: must be 0 with discretisation.mass = "redistributed"'),
    (["discretisation.mass=redistributed", "time.scheme=crank-nicolson", "model.zeta=0",
      "model.a=0", "source.momentum=x*t"],
     'source.momentum: not with discretisation.mass = "redistributed"'),
    (["source.heat=exp(-t)*y"], "source.heat: \"exp(-t)*y\" uses unknown name 'y'"),
    (["initial.u1=t*x"], "initial.u1: \"t*x\" uses unknown name 't'"),
    (["source.momentum=log(x - t)"], "source.momentum: not finite at x = 0, t = 0.001"),
    (["source.heat=1/(t - 8)"], "source.heat: not finite at x = 0, t = 8"),
    (["source.mass=1"], "unknown key 'source.mass'"),
    (["output.probes=[0.5, 1.5]"], "output.probes[1]: must be <= 1, got 1.5"),
    (["output.probes=[-0.1]"], "output.probes[0]: must be >= 0, got -0.1"),
    (["output.probes=[0.25, 0.5, 0.25]"], "output.probes: 0.25 is listed twice"),
    (["output.probes=[0.5, 0.50]"], "output.probes: 0.5 is listed twice"),
    (["output.probes=0.5"], "output.probes: must be a list"),
    (["output.probes=[nan]"], "output.probes[0]: must be finite"),
    (['output.probes=["x"]'], "output.probes[0]: must be a number"),
    (['output.fields=["u", "temperature"]'],
     'output.fields[1]: must be one of "theta" | "u" | "sigma" | "velocity" | "heat_flux", '
     'got "temperature"'),
    (['output.fields=["u", "u"]'], 'output.fields: "u" is listed twice'),
    (["output.fields=[]"], "output.fields: must name at least one of theta, u, sigma"),
    (['output.history=["u_1"]'], 'output.history[0]: must be one of "theta_1" |'),
    (['output.history=["contact", "contact"]'], 'output.history: "contact" is listed twice'),
]


def _run(argv, capsys):
    code = main(argv)
    err = capsys.readouterr().err
    return code, err


@pytest.mark.parametrize("overrides, message", CASES, ids=[c[1][:40] for c in CASES])
def test_bad_value(overrides, message, shared_dir, capsys):
    out = shared_dir / "out"
    argv = ["run", "paper1", "--out", str(out)]
    for item in overrides:
        argv += ["--set", item]
    code, err = _run(argv, capsys)
    assert code == 2
    if COMM.rank == 0:
        assert message in err
        assert err.count("\n") == 1 and err.startswith("rodfem: error: ")
        assert "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize(
    "text, message",
    [
        ("[model\na = 1", "invalid TOML"),
        ("[model]\na = [1, 2]", "model.a: must be a number"),
        ("model = 3", "model: must be a section"),
        ("description = 3", "description: must be a string"),
        ("[time]\ndt = 0.1\nend = 0.05", "time.dt: must be <= time.end"),
    ],
)
def test_bad_file(text, message, shared_dir, capsys):
    scene = shared_dir / "scene.toml"
    if COMM.rank == 0:
        scene.write_text(text)
    COMM.barrier()
    out = shared_dir / "out"
    code, err = _run(["run", str(scene), "--out", str(out)], capsys)
    assert code == 2
    if COMM.rank == 0:
        assert message in err and err.count("\n") == 1
    assert not out.exists()


def test_unknown_scene(shared_dir, capsys):
    out = shared_dir / "out"
    code, err = _run(["run", "paper9", "--out", str(out)], capsys)
    assert code == 2
    if COMM.rank == 0:
        builtin = ("paper1, paper2, paper3, paper4, paper5, manufactured, manufactured-gap, "
                   "impact, stiff, barber")
        assert f"not a built-in scene ({builtin}) nor a TOML file" in err
    assert not out.exists()


def test_existing_directory_is_kept(shared_dir, capsys):
    out = shared_dir / "out"
    if COMM.rank == 0:
        out.mkdir()
        (out / "history.csv").write_text("precious\n")
    COMM.barrier()
    code, err = _run(["run", "paper1", "--out", str(out), "--set", "time.end=0.01"], capsys)
    assert code == 2
    if COMM.rank == 0:
        assert "exists; use --force" in err
    assert (out / "history.csv").read_text() == "precious\n"


def test_force_never_deletes_a_foreign_directory(shared_dir, capsys):
    out = shared_dir / "mine"
    if COMM.rank == 0:
        out.mkdir()
        (out / "thesis.tex").write_text("precious\n")
    COMM.barrier()
    code, err = _run(["run", "paper1", "--out", str(out), "--force", "--set", "time.end=0.01"],
                     capsys)
    assert code == 2
    if COMM.rank == 0:
        assert "not a rodfem output directory (it has no rodfem.json)" in err
    assert (out / "thesis.tex").read_text() == "precious\n"


def test_force_replaces_a_run(shared_dir, capsys):
    out = shared_dir / "out"
    argv = ["run", "paper1", "--out", str(out), "--quiet", "--set", "time.end=0.01"]
    assert main(argv) == 0
    assert main(argv) == 2
    assert main(argv + ["--force", "--set", "time.end=0.02"]) == 0
    if COMM.rank == 0:
        assert len(history_rows(out)) == 21


def _one_line(code, err, message):
    assert code == 2
    if COMM.rank == 0:
        assert message in err, err
        assert err.count("\n") == 1 and err.startswith("rodfem: error: ") and "Traceback" not in err


@pytest.mark.parametrize("command", ["run", "sweep"])
@pytest.mark.parametrize("kind", ["character device", "pipe", "directory"])
def test_devices_pipes_and_directories_are_refused_unread(command, kind, shared_dir, capsys):
    """/dev/zero would be read without end and a pipe without a writer would wait forever: a
    scene or a sweep file must be a regular file, refused otherwise before it is opened for
    reading (a pipe opened to be read would block here)."""
    path = {"character device": Path("/dev/zero"), "pipe": shared_dir / "pipe",
            "directory": shared_dir / "dir"}[kind]
    if COMM.rank == 0 and kind == "pipe":
        os.mkfifo(path)
    if COMM.rank == 0 and kind == "directory":
        path.mkdir()
    COMM.barrier()
    out = shared_dir / "out"
    code, err = _run([command, str(path), "--out", str(out)], capsys)
    _one_line(code, err, f"not a regular file but a {kind}; give a TOML file")
    assert not out.exists()


def test_a_sweeps_base_scene_must_be_a_regular_file(shared_dir, capsys):
    sweep = shared_dir / "sweep.toml"
    if COMM.rank == 0:
        os.mkfifo(shared_dir / "pipe")
        sweep.write_text('scene = "pipe"\n[grid]\n"model.k" = [1, 2]\n')
    COMM.barrier()
    out = shared_dir / "out"
    code, err = _run(["sweep", str(sweep), "--out", str(out)], capsys)
    _one_line(code, err, "scene '")
    if COMM.rank == 0:
        assert "pipe': not a regular file but a pipe" in err
    assert not out.exists()


SPACED = {
    "leading": ('[grid]\n" model.k" = [1, 2]\n', '" model.k" has a space in it'),
    "trailing, beside the key": ('[grid]\n"model.k" = [1, 2]\n"model.k " = [3, 4]\n',
                                 '"model.k " has a space in it; write the key alone, "model.k"'),
    "set, and spaced in grid": ('[set]\n"model.k" = 1\n[grid]\n"model.k\t" = [3, 4]\n',
                                '"model.k\\t" has a space in it'),
    "inside": ('[zip]\n"model. k" = [1, 2]\n', '"model. k" has a space in it'),
    "sampled": ('[sample]\ncount = 2\n[sample.ranges]\n"model.k " = [1, 2]\n',
                '"model.k " has a space in it'),
}


@pytest.mark.parametrize("case", sorted(SPACED))
def test_sweep_keys_with_spaces_are_refused(case, shared_dir, capsys):
    """A key with spaces would be another key to the sweep's table (rows labelled with one
    key's values, run with the other's) and the same key to the scene."""
    body, message = SPACED[case]
    sweep = shared_dir / "sweep.toml"
    if COMM.rank == 0:
        sweep.write_text(f'scene = "paper1"\n{body}')
    COMM.barrier()
    out = shared_dir / "out"
    code, err = _run(["sweep", str(sweep), "--out", str(out)], capsys)
    _one_line(code, err, message)
    assert not out.exists()


@pytest.mark.parametrize("item", [" model.k=2", "model.k =2", "model .k=2"])
def test_set_keys_with_spaces_are_refused(item, shared_dir, capsys):
    out = shared_dir / "out"
    code, err = _run(["run", "paper1", "--out", str(out), "--set", item], capsys)
    _one_line(code, err, "has a space in it; write the key alone")
    assert not out.exists()


def test_python_sweep_keys_with_spaces_are_refused(tmp_path):
    with pytest.raises(SceneError, match="has a space in it"):
        rodfem.sweep({"scene": "paper1", "grid": {"model.k": [1, 2], "model.k ": [3, 4]}},
                     out=tmp_path / "out", comm=MPI.COMM_SELF)
    assert not (tmp_path / "out").exists()


MEASURES = {
    "column": ('p = { column = "u_2", reduce = "max" }',
               "measures.p: unknown column 'u_2'; allowed: t, u_1,"),
    "reduce": ('p = { column = "u_1", reduce = "maxx" }',
               "measures.p: unknown reduce 'maxx'; allowed: max, min, max_abs,"),
    "key": ('p = { column = "u_1", reduce = "max", when = 1 }',
            "measures.p: unknown key 'when'; allowed: column, reduce, window"),
    "window": ('p = { column = "u_1", reduce = "max", window = [0.5, 0.1] }',
               "measures.p: window [0.5, 0.1] must have 0 <= t0 < t1"),
    "window after the end": ('p = { column = "u_1", reduce = "max", window = [9, 10] }',
                             "measures.p: window starts at 9.0, at or after time.end = 8.0"),
    "probe": ('p = { column = "u@2", reduce = "max" }', "the point x of u@x must be a number"),
    "adaptive only": ('p = { column = "dt", reduce = "max" }',
                      "column 'dt' is recorded only with time.adaptive = true"),
    "built-in name": ('t_final = { column = "t", reduce = "final" }',
                      "measures.t_final: 't_final' is a built-in measure"),
    "name": ('Peak = { column = "t", reduce = "final" }',
             "measures.Peak: a measure's name must be lower-case letters"),
    "missing": ('p = { reduce = "max" }', "measures.p: needs a column"),
}


@pytest.mark.parametrize("command", ["run", "sweep"])
@pytest.mark.parametrize("case", sorted(MEASURES))
def test_bad_measures_are_refused(command, case, shared_dir, capsys):
    """A scene's or a sweep's [measures]: one line naming the measure and what is allowed,
    nothing written."""
    entry, message = MEASURES[case]
    path = shared_dir / "file.toml"
    if COMM.rank == 0:
        head = 'scene = "paper1"\n[grid]\n"model.k" = [1, 2]\n' if command == "sweep" else ""
        path.write_text(f"{head}[measures]\n{entry}\n")
    COMM.barrier()
    out = shared_dir / "out"
    code, err = _run([command, str(path), "--out", str(out)], capsys)
    _one_line(code, err, message)
    assert not out.exists()


def test_a_sweep_may_not_declare_a_measure_its_scene_declares(shared_dir, capsys):
    if COMM.rank == 0:
        (shared_dir / "base.toml").write_text('[measures]\np = { column = "t", reduce = "max" }\n')
        (shared_dir / "sweep.toml").write_text(
            'scene = "base.toml"\n[grid]\n"model.k" = [1, 2]\n'
            '[measures]\np = { column = "u_1", reduce = "max" }\n')
    COMM.barrier()
    out = shared_dir / "out"
    code, err = _run(["sweep", str(shared_dir / "sweep.toml"), "--out", str(out)], capsys)
    _one_line(code, err, "sweep.toml: measures.p is declared by the base scene too")
    assert not out.exists()


@pytest.mark.parametrize("args", [
    ["run", "paper1", "--out", "a\0b"], ["sweep", "s.toml", "--out", "a\0b"],
    ["fit", "f.toml", "--out", "a\0b"], ["sensitivity", "s.toml", "--out", "a\0b"],
    ["steady", "paper1", "--out", "a\0b"], ["resume", "a\0b"], ["plot", "a\0b"],
    ["verify", "--quick", "--out", "a\0b"],
], ids=lambda args: args[0])
def test_a_path_with_a_nul_is_a_mistake_in_the_arguments(args, capsys):
    """A caller of main() can pass a NUL in a path (a shell cannot): the path's first use
    raised ValueError, a traceback; it is now refused with the other mistakes in arguments."""
    with pytest.raises(SystemExit) as stopped:
        main(args)
    err = capsys.readouterr().err
    assert stopped.value.code == 2
    assert "holds a NUL character, which no path can" in err and err.count("\n") == 1, err


def test_the_api_refuses_an_output_directory_with_a_nul(shared_dir):
    with pytest.raises(rodfem.OutputError, match="a path cannot hold a NUL character"):
        rodfem.simulate("paper1", {"time.end": 0.01}, out=str(shared_dir / "a\0b"))


@pytest.mark.parametrize("force", [False, True])
def test_an_output_directory_that_is_a_loop_of_links_is_refused(force, shared_dir, capsys):
    out = shared_dir / "loop"
    if COMM.rank == 0:
        out.symlink_to("loop")
    COMM.barrier()
    code, err = _run(["run", "paper1", "--out", str(out), "--set", "time.end=0.01",
                      *(["--force"] if force else [])], capsys)
    assert code == 2 and out.is_symlink()
    if COMM.rank == 0:
        assert err.startswith("rodfem: error: ") and err.count("\n") == 1, err
        assert ("exists and is not a directory" if force else "exists; use --force") in err
    code, err = _run(["run", "paper1", "--out", str(out / "x"), "--set", "time.end=0.01"], capsys)
    assert code == 2
    if COMM.rank == 0:
        assert "Too many levels of symbolic links" in err and err.count("\n") == 1, err


def test_a_command_in_the_tests_process_leaves_its_handlers_to_the_next_test():
    """(first of a pair, run in this order) ``main`` installs rodfem's stop-signal handlers
    for the rest of its process."""
    from rodfem.output import interrupts

    assert main(["run", "no-such-scene"]) == 2
    assert any(signal.getsignal(s) is interrupts._handler for s in interrupts.SIGNALS)


def test_the_next_test_has_the_test_process_handlers():
    """(second of the pair) the conftest puts the test process's own handlers back after each
    test, whatever ran before it in this process (this file's test before it, or another file's
    module fixture): a signal to a test worker (a CI's time limit) ends it without rodfem's
    handling."""
    from conftest import PROCESS_HANDLERS

    assert {s: signal.getsignal(s) for s in PROCESS_HANDLERS} == PROCESS_HANDLERS
