"""MuJoCo digital twin of a five-bar pot-seedling transplanter and its PGF/SGF firmware."""

__version__ = "0.1.0"
