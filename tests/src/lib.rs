//! Integration tests of the probes workspace live in `tests/tests/`.
