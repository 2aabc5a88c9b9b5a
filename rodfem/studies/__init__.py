"""Commands over many runs, by what a user asks for: :mod:`~rodfem.studies.sweep` (many scenes
of one sweep file, their measures in one table: the engine the others run on),
:mod:`~rodfem.studies.fit` (a scene's parameters fitted to measured data),
:mod:`~rodfem.studies.sensitivity` (which parameters the measures depend on),
:mod:`~rodfem.studies.verification` (observed orders, stability maps, work-precision, the paper's
Section 6) and :mod:`~rodfem.studies.steady` (steady states, their stability and branches).

Shared by them: :mod:`~rodfem.studies.common` (a study's directory, its CSV, the machine it ran
on, the dealing of tasks to the ranks), :mod:`~rodfem.studies.cost` (a study's cost measured
before it runs) and :mod:`~rodfem.studies.damage` (a study directory's files checked before it
is continued). A family imports these and the sweep engine, never another family."""
