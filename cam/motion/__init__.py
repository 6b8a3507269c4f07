"""Machine motion and dynamics (methods M5 and M6).

Modules, one step of the method each:

* ``scurve``: seven-segment asymmetric jerk profiles, vectorised (seed 000).
* ``plant``: the two-degree-of-freedom indexing-table plant, exact ZOH simulation.
* ``identify``: plant parameters from a measured response CSV (least squares).
* ``positioning``: positioning time = access + settling, closed form.
* ``optimise`` / ``plots``: the paper's grid search on Dask, Figs. 9 and 10.
* ``feeddrive`` / ``synchronisation``: feed-drive model, Best K_FFP, torque
  saturation, the circle test (seed 004).
* ``program_servo``: servo lag of a joint-space program mapped to the tool tip.
* ``cycle_time``: program and index-move times under axis limits.
* ``cli``: the ``impeller-cam motion`` sub-commands.

Heavy modules are not imported here; import the one you need.
"""
