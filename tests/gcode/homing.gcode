; Homing (G28): the switches, the pulled-off position, homing again.

M119 ; expect: endstops: 1:open 2:open 3:open 4:open | ok
M114 ; expect: X:nan Y:nan Z:nan A:0 B:0 C:0 | ok
G28 ; expect: ok
; switches 1-3 at theta1 = 200 deg, theta2 = -20 deg, Z = 160 mm, less the pull-off
M114 ; expect: X:0.000 Y:78.988 Z:159.000 A:5237 B:-437 C:63600 | ok
M119 ; expect: endstops: 1:open 2:open 3:open 4:open | ok
G90 ; expect: ok
G1 X0 Y200 Z6 S100 ; expect: ok
; Z down at 6 mm: switch 4 sits at z_min (5 mm), still open
M119 ; expect: endstops: 1:open 2:open 3:open 4:open | ok
G1 Z5 ; expect: ok
M119 ; expect: endstops: 1:open 2:open 3:open 4:TRIGGERED | ok
G28 ; expect: ok
M114 ; expect: X:0.000 Y:78.988 Z:159.000 A:5237 B:-437 C:63600 | ok
G28 X0 ; expect: error:36
