"""RobWoT's benchmarks, the independent collision reference and the example-scene generator.

They measure and check the backend (`robwot_sim`) from outside: nothing in `robwot_sim` imports them.
`npm run bench:backend` / `bench:scale` / `bench:fidelity` run `python -m robwot_bench.<name>`.
"""
