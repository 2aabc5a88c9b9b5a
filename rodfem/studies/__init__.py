"""Commands that run many scenes: ``verify`` (observed orders), ``stability`` (where each method
converges), ``workprecision`` (accuracy against time) and ``paper`` (the paper's Section 6), on
the shared ``convergence``, ``common`` and ``orders`` (verify's report) modules."""
