"""Colours and text sizes shared by every figure, so that one thing looks the same in each of them.

The colours are matplotlib's ``tab10`` written as hex, which plotly reads too: truth green,
estimates red, cameras blue, detection boxes orange. Figures import them from here and never
spell a colour of their own for these things.
"""

from __future__ import annotations

#: True fruit (matplotlib "tab:green"); translucent in the 3D view.
TRUTH_COLOUR = "#2ca02c"
#: Estimated fruit (matplotlib "tab:red"), in every figure; one colour, whatever the score.
ESTIMATE_COLOUR = "#d62728"
#: Cameras: frusta, their numbers and the path of chosen poses (matplotlib "tab:blue").
CAMERA_COLOUR = "#1f77b4"
#: Detection boxes on the 3D view's image planes (matplotlib "tab:orange").
BOX_COLOUR = "#ff7f0e"
#: Viewing cones of boxes (matplotlib "tab:purple").
CONE_COLOUR = "#9467bd"
#: Errors: lines from an estimate to its matched truth, 95 % position-error ellipsoids.
ERROR_COLOUR = "#d62728"
#: The session's workspace box (matplotlib "tab:gray").
WORKSPACE_COLOUR = "#7f7f7f"
#: Leaves.
OCCLUDER_COLOUR = "darkolivegreen"
#: Stems.
STEM_COLOUR = "saddlebrown"
#: Candidate poses of the active-perception figure.
CANDIDATE_COLOUR = "0.7"

#: Text sizes, points: panel titles, legends, tick labels, the numbers on fruit and cameras.
TITLE_SIZE = 9
LEGEND_SIZE = 9
TICK_SIZE = 7
NUMBER_SIZE = 10
