"""Our parts of SPH: what we added to the paper's method, each switched by its own parameter and
off in ``preset=paper`` (the default build today; ``swarmnav methods sph`` lists what each preset
switches on).

- ``yielding``: a queue in narrow places (``yield_range`` > 0; presets ``queue``, ``guard``,
  ``retime``);
- ``guard``: the band guard on the tracking term (``band_guard``; preset ``guard``);
- ``retime``: local plans the spline cuts short optimised again (``retime`` > 0; preset ``retime``).

Our other switches are small branches of the core's replanning, named by their parameters,
documented in docs/methods/sph.md and mapped in docs/methods/builds.md: the lag bounds
``ref_reset`` / ``goal_reset`` / ``ref_hold`` / ``start_clearance`` and the plan speed
``plan_v_max``.
"""
