"""How far the numbers can be trusted: ``rodfem verify`` (observed orders in h and Δt, of the
built-in scenes and a user's own), ``rodfem stability`` (where each method converges),
``rodfem work-precision`` (accuracy against time) and ``rodfem paper`` (the paper's Section 6).

:mod:`~.convergence` (the error measures and rate fits they share), :mod:`~.verify`,
:mod:`~.ladders` (a user's scenes and their ladders) and :mod:`~.refine` (the ladders of runs),
:mod:`~.asymptotic` (what an order is worth: checked against the expected one), :mod:`~.orders`
(verify's report), :mod:`~.stability`, :mod:`~.workprecision` and :mod:`~.paper`."""
