; Servos (M280), dwell (G4), conveyor (M710) and the other M codes; none needs homing.

M280 P0 S155 ; expect: ok in 0 s
M280 P1 S0 ; expect: ok
M280 P1 S180 ; expect: ok
M280 P2 S10 ; expect: error:63 M280 P2: servo index must be 0 (gripper) or 1 (wrist)
M280 P0 S180.5 ; expect: error:63 M280 S180.5: servo angle must be within 0-180 degrees
M280 P1 S-1 ; expect: error:63
M280 S90 ; expect: error:28
M280 P0 ; expect: error:28
M280 P0 S10 S20 ; expect: error:25
G4 P250 ; expect: ok in 0.25 s
G4 P0 ; expect: ok in 0 s
G4 P-1 ; expect: error:4
G4 ; expect: error:28
G4 P10 X1 ; expect: error:36
M710 ; expect: ok in 0.6 s
M400 ; expect: ok
M105 ; expect: ok
M400 S1 ; expect: error:36
