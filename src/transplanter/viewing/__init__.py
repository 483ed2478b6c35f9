"""Recording, playback, video and the live viewer."""
