; Lines the parser refuses, one per error code, and the ASCII-only dialect.

G28 ; expect: ok
#G1 X1 ; expect: error:1 expected a command letter, found '#'; remove the character
X10 Y5 ; expect: error:1 the line has no G or M command; start it with e.g. G1
G1 X1 ) ; expect: error:1
G1 X1.2.3 ; expect: error:2
G1 X ; expect: error:2 word X is followed by nothing, not a number; write e.g. X10.5
G1 Xnan ; expect: error:2
G1 X1 F-100 ; expect: error:4
G1 X11111111111111111111111111111111111111111111111111111111111111111111111111111111 ; expect: error:11
G2 X1 Y1 ; expect: error:20
M999 ; expect: error:20 unsupported command M999; supported: G0 G1 G4 G28 G90 G91 M280 M400 M114 M119 M105 M710
G90 G1 X1 ; expect: error:21
G1 X1 S0 ; expect: error:22
M280 P0.5 S10 ; expect: error:23
G1 X1 X2 ; expect: error:25
G1 S100 ; expect: error:26
G4 ; expect: error:28
G28 X0 ; expect: error:36
G1 X1 F600 S10 ; expect: error:36
G1 X1 (unclosed comment ; expect: error:64
; non-ASCII: Python's float() would read these digits as 10 and 140
G1 X١٠ Y180 ; expect: error:2 non-ASCII character U+0661 (ARABIC-INDIC DIGIT ONE) in 'X١٠'; G-code is ASCII, write digits 0-9
G1 X0 Y１４０ ; expect: error:2 non-ASCII character U+FF11 (FULLWIDTH DIGIT ONE) in 'Y１４０'; G-code is ASCII, write digits 0-9
G1 X0 Y180 ; expect: error:1 non-ASCII character U+00A0 (NO-BREAK SPACE); G-code is ASCII, remove the character
G1　X0 Y180 ; expect: error:1 non-ASCII character U+3000 (IDEOGRAPHIC SPACE)
G90 (café) ; expect: error:1 non-ASCII character U+00E9
; blank and comment-only lines give no reply at all
   ; expect: none
(just a comment) ; expect: none
; after all that the machine still answers
M105 ; expect: ok
