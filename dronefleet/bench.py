"""Benchmarks of both scenarios: ``python -m dronefleet.bench [delivery|replenishment] [options]``.

``delivery`` passes its options to :mod:`dronefleet.delivery.bench` (``--help`` lists
them: compile time, per-run phases, ``--scaling``, ``--big``, ``--process``, ``--sweep``);
``replenishment`` runs :mod:`dronefleet.replenishment.bench`. Without a scenario, both
run with their defaults, delivery first. It prints; it asserts nothing.
"""

import sys


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    scenario = argv.pop(0) if argv and argv[0] in ("delivery", "replenishment") else None
    if scenario in (None, "delivery"):
        from .delivery.bench import main as delivery

        print("== delivery ==")
        delivery(argv)
    if scenario in (None, "replenishment"):
        from .replenishment.bench import bench_replenishment

        print("== replenishment ==")
        bench_replenishment()


if __name__ == "__main__":
    main()
