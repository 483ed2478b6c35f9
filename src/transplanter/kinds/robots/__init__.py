"""The robots kinds (transplanter.kinds)."""
