#!/usr/bin/env python3
"""Reproduce a figure of a study: ``python experiments/reproduce.py FIGURE|all [--quick]``, FIGURE one of
``dronefleet reproduce --list`` (fig09-fig12, fig16-fig20, items-fig01-items-fig12, items-ttests, items-verdicts).

``experiments/<figure>.py`` are links to this script that reproduce their figure
(``python experiments/fig16.py --quick``). Same as ``dronefleet reproduce``, options
included (``--out DIR``, default ``dronefleet-results/``; ``--update-results`` for the
committed ``results/``); see ``results/README.md`` for what each figure runs and shows.
"""

import sys
from pathlib import Path

from dronefleet.cli import main

figure = Path(sys.argv[0]).stem
sys.exit(main(["reproduce", *([] if figure == "reproduce" else [figure]), *sys.argv[1:]]))
