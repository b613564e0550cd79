"""The palette every figure shares, 2-D and 3-D: obstacles, goal, spawn, path, start and end
positions, structural-event markers. One place, so a scene looks the same in every drawing."""

OBSTACLE_FACE = "#b3d9f2"  # light blue, as the obstacles of HES Figure 3
OBSTACLE_EDGE = "#4d7ea8"
GOAL_FACE = "#ffd400"
SPAWN_COLOR = "tab:green"
PATH_COLOR = "tab:purple"
START_COLOR = "tab:green"
END_COLOR = "tab:red"
#: Marker of each structural event action in trajectory figures.
EVENT_MARKERS = {"split": ("^", "black"), "merge": ("D", "white")}  # outside tab10/tab20
