"""The end effectors of the scene, one module per kind (registered in scene.kinds)."""
