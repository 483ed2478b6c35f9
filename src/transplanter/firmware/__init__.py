"""The two firmwares of the paper (PGF, SGF), the EEPROM image and the COM bus between them.

Pure numpy: nothing here imports MuJoCo, so the same code can later drive real hardware.
"""
