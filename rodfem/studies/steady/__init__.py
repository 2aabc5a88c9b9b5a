"""``rodfem steady`` and ``rodfem.steady``: every steady state of a scene with its stability, and
their branches over a scene value; time runs read against them.

:mod:`~.states` (the states, their stability and branches) and :mod:`~.barber` (runs started at
or near a state: the step's rate, periods, contact cycles)."""
