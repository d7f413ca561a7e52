"""The commands and the life of a job and of a sweep: the console scripts (:mod:`~dsmv.app.cli`), the
command line's checks (:mod:`~dsmv.app.command_line`), one job (:mod:`~dsmv.app.runner`), a sweep's
main process (:mod:`~dsmv.app.sweep`), their signals (:mod:`~dsmv.app.interrupts`) and logs
(:mod:`~dsmv.app.joblog`), and the plugin template (:mod:`~dsmv.app.template`)."""
