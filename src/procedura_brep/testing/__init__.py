"""Test support that ships with the package: tape builders for the staged agent.

Nothing here is used by the tool itself; tests, benchmarks and the tape generators in
``tests/tapes/`` import it (so two test folders never import each other's conftest).
"""
