"""The discrete setting: the interval mesh, P1 spaces and measures, the node order every rank
shares, the operators read off the forms of ``forms/``, and the dolfinx version differences
(``compat``)."""
