"""rodfem: dynamic contact of a thermoviscoelastic rod with an obstacle, in FEniCSx.

Copetti's scheme: a heat equation coupled to a Kelvin–Voigt wave equation on (0, 1), penalty
contact with an elastic obstacle at x = 1, P1 elements and a Picard loop per time step.

From Python: :func:`simulate` runs a scene, :func:`load` reads a run directory, both give a
:class:`Result`; :func:`sweep` runs a sweep file (:mod:`rodfem.studies.sweep.run`);
:func:`read_fields` reads any run's ``fields.xdmf`` into NumPy (:class:`Fields`); :func:`steady`
gives a scene's steady states and their stability, :func:`bifurcation` their branches over a
scene value with the folds, grazing and Hopf points on them. The errors they raise are here too
(:class:`SceneError`, :class:`OutputError`, :class:`RunDirectoryError`, :class:`ResultsError`,
:class:`FieldsError`, :class:`FitError`, and :class:`Interrupted` for a stop signal). Every
name of :data:`__all__` is imported on first use, so that ``import rodfem`` stays light, and
``dir(rodfem)`` lists them all.
"""

__version__ = "0.1.0"

_API = {"simulate": "rodfem.api", "load": "rodfem.api", "Result": "rodfem.api",
        "SceneError": "rodfem.scene", "OutputError": "rodfem.output.directories",
        "sweep": "rodfem.studies.sweep.run", "load_sweep": "rodfem.studies.sweep.run",
        "read_fields": "rodfem.output.readers", "Fields": "rodfem.output.readers",
        "CoarseStepWarning": "rodfem.model.timescales", "steady": "rodfem.api",
        "bifurcation": "rodfem.api",
        "AccuracyWarning": "rodfem.studies.accuracy.ladder",
        "Scene": "rodfem.scene", "SweepResult": "rodfem.studies.sweep.files",
        "sensitivity": "rodfem.studies.sensitivity.run",
        "load_sensitivity": "rodfem.studies.sensitivity.files",
        "SensitivityResult": "rodfem.studies.sensitivity.files",
        "fit": "rodfem.studies.fit.run", "load_fit": "rodfem.studies.fit.files",
        "FitResult": "rodfem.studies.fit.files", "FitError": "rodfem.studies.fit.files",
        "RunDirectoryError": "rodfem.output.readers", "ResultsError": "rodfem.output.results",
        "FieldsError": "rodfem.output.readers", "Interrupted": "rodfem.output.interrupts"}
__all__ = [*_API, "__version__"]


def __getattr__(name: str):
    if name in _API:
        import importlib

        module = importlib.import_module(_API[name])
        return getattr(module, name)
    raise AttributeError(f"module 'rodfem' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The package's own names and the API's, which :func:`__getattr__` imports when asked."""
    return sorted({*globals(), *__all__})
