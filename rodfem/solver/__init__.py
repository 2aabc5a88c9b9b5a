"""The time loop's algebra: the time schemes (``time_schemes``), the methods that solve a step
(``methods/``, by registry), their compiled loops (``compiled/``) and the errors a step raises."""
