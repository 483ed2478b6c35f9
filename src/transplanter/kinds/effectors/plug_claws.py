"""Seed 002's plug-in claws: pins into the plug, a stripper, a rotary cylinder."""

from transplanter.kinds.interfaces import ALL

NAME = "plug_claws"
SUMMARY = "plug-in claws with a stripper on a rotary cylinder (seed 002)"
SCENE = "transplanter.scene.effectors.plug_claws"
MODEL = "plug_claws"
READS = {"plug_claws": ALL}
