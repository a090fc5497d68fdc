"""Benchmarks: ``eyelab bench ...`` print numbers and write JSON; never timed unit tests."""
