; One pick-and-drop of pickup 3 (the middle cell), as the PGF sends it (Algorithm 2),
; with the taught values of scenarios/paper.toml.
G28                      ; home on limit switches 1, 2 and 3
G90                      ; absolute coordinates
M280 P1 S135             ; wrist to the drop elbow M_dep
G1 X0 Y140 Z60 S150      ; to the drop point, the cycle's initial position
G1 X0 Y180 Z34 S150      ; approach (via) point at Z_low, S_h = 150 mm/s
M280 P1 S135.8           ; wrist (elbow) for this pickup, M_pep
M280 P0 S155             ; open the gripper
G4 P200                  ; let the servo open
G1 X0 Y215 Z34 S60       ; slide the jaws around the pot, S_l = 60 mm/s
M280 P0 S90              ; close the gripper
G4 P300                  ; let the servo squeeze
G1 X0 Y215 Z60 S60       ; lift to Z_up
G1 X0 Y180 Z60 S150      ; back to the approach point
M280 P1 S135             ; wrist for the drop
G1 X0 Y140 Z60 S150      ; over the drop tube
M280 P0 S155             ; release
G4 P200
M400
