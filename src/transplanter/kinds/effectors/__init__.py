"""The effectors kinds (transplanter.kinds)."""
