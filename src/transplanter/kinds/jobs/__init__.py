"""The jobs kinds (transplanter.kinds)."""
