; Motion: the alarm lock before homing, absolute and relative moves, speeds, bad targets.
; Paper machine (SGFConfig defaults): motors 100 mm apart, links 120/200 mm, Z 5-160 mm.

G1 X0 Y200 Z60 S100 ; expect: error:9 position unknown: home first with G28
G28 ; expect: ok
G90 ; expect: ok
G1 X0 Y200 Z60 S100 ; expect: ok
M114 ; expect: X:0.000 Y:200.000 Z:60.000 A:3893 B:907 C:24000 | ok
G0 X-50 Y180 ; expect: ok
G1 X50 Y180 F6000 ; expect: ok
G91 ; expect: ok
G1 X-10 Y20 Z-20 ; expect: ok
M114 ; expect: X:40.000 Y:200.000 Z:40.000 A:3479 B:545 C:16000 | ok
G90 ; expect: ok
G1 X0 Y400 Z50 ; expect: error:33 target position not reachable
G1 X0 Y200 Z200 ; expect: error:33 Z 200.000 mm outside [5, 160] mm
G1 X0 Y200 Z1 ; expect: error:33
; a refused move leaves the position (and the modal speed) as it was
M114 ; expect: X:40.000 Y:200.000 Z:40.000 A:3479 B:545 C:16000 | ok
G1 X0 Y60 Z50 ; expect: error:33
G1 Z100 S50 ; expect: ok in 1.223 s
M400 ; expect: ok
