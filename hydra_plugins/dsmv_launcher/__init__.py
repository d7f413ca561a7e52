"""``hydra/launcher=dsmv_local``'s launcher: Hydra's submitit local launcher with a worker per core
(:mod:`.submitit_workers`). It lives in ``hydra_plugins`` because Hydra only instantiates launchers
from that namespace."""
