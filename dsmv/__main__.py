"""``python -m dsmv`` is ``dsmv``."""

from dsmv.app.cli import simulate

if __name__ == "__main__":
    simulate()
