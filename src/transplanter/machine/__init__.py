"""The machine's firmware side, pure numpy (never imports MuJoCo): kinematics, G-code, motion,
steppers, homing, the SGF and PGF firmware, EEPROM, bus, Marlin framing,
serial host, faults, HMI."""
