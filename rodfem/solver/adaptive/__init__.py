"""Adaptive time steps: the error estimate and the controller (:mod:`.control`, NumPy only), and
the steps of any method taken with them, contact events located (:mod:`.stepper`)."""
