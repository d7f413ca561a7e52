"""``hydra/launcher=dsmv_local`` and ``dsmv_slurm``'s launchers: Hydra's submitit launchers with a
worker per core on this machine and time limits from the jobs' cost estimates
(:mod:`.submitit_launchers`). They live in ``hydra_plugins`` because Hydra only instantiates
launchers from that namespace."""
