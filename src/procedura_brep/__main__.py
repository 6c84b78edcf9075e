"""``python -m procedura_brep``: the command line (the same as ``procedura-brep``)."""

from .entry import main

main()
