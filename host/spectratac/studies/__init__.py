"""What only the digital twin can tell: the twin oracle's floor (`oracle_floor`), the twin's
fidelity against the paper (`twin_fidelity`) and the decoder benchmarks on twin sessions
(`bench`). Beside `sim`, outside the data flow: it builds on twin, sim and the data flow up
to apps, and only the command line imports it (tests/meta/test_layering.py)."""
