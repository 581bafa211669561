"""Benchmarks shared by the CLI (`monovisual3d bench ...`) and benchmarks/*.py."""
