"""Test support that ships with the package (nothing in the tool itself imports it).

* :mod:`.programs`: program text builders (a tower of N blocks joined by mates, five-block
  part replies) for tests and benchmarks;
* :mod:`.models`: hand-built compiled models for gate tests, a compile-cleanly helper and
  :func:`~procedura_brep.testing.models.rebuilt` (which parts a compile ran);
* :mod:`.tapes`: tape builders for the staged agent.

Tests, benchmarks and the tape generators in ``tests/tapes/`` import these, so no test folder
imports another's ``conftest`` (which breaks when two folders are collected together).
"""
