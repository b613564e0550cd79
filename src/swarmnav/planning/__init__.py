"""What the trajectory planners share: SPH (``methods.sph``) and the Table II peers.

- :mod:`~swarmnav.planning.bspline`: uniform cubic B-splines (basis, boundary states of eq. 12,
  sampling) and the ESDF-based spline optimiser of the SPH paper (L-BFGS, compiled);
- :mod:`~swarmnav.planning.maps`: per-robot occupancy maps built from what each robot has
  sensed, and the grid search (A*, 2-D and 3-D) that seeds a spline;
- :mod:`~swarmnav.planning.schedule`: the replanning period ``T_p`` in control steps;
- :mod:`~swarmnav.planning.tracker`: references sampled from each robot's plan at the control
  rate, and the tracking law of SPH eq. (13) that follows them;
- :mod:`~swarmnav.planning.messages`: what the robots broadcast (positions, trajectories), each
  message counted with its size in bytes, so the ``comm_mbps`` metric is measured from the
  messages a planner actually sent;
- :mod:`~swarmnav.planning.plan_log`: the trajectories a planner committed, sampled for replay
  (what its optional ``plans()`` hook returns);
- :mod:`~swarmnav.planning.goals`: per-robot goal slots around the scene's goal.

A planner is its paper's cost terms and decisions on top of these parts.
"""
