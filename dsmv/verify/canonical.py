"""The canonical scenes, each as the overrides of one run.

The verification experiments (``conf/experiment/verify_*.yaml``) define the cases once; run as a
single job (``hydra.mode=RUN``) they are the scenes that ``dsmv-bench``, the regression scenes and
the tests start from, adding only what differs (a mesh, a travel, a contact rule).
"""

from __future__ import annotations

#: Prandtl's strip: a rough rigid strip B = 1 m pushed at 0.1 m/s into weightless Tresca soil
#: (su 10 kPa), the soil free to part from its walls, core cells B/20, to 1 B
PRANDTL = ("experiment=verify_prandtl", "hydra.mode=RUN")
#: the same strip with the soil tied to its walls
PRANDTL_BONDED = (*PRANDTL, "solver.contact_separation=false")
#: a rough cylinder D = 0.5 m, 3 D deep in weightless Tresca soil, pushed 2 D at D/20
TBAR = ("experiment=verify_tbar", "hydra.mode=RUN")
#: the default landing on the CEL solver
LANDING = ("solver=cel2d",)
