; Marlin framing: N<n> <command> *<checksum>, the checksum the XOR of the bytes before '*'.

N1 G28*18 ; expect: ok
N2 G90*18 ; expect: ok
; out of sequence: N3 is expected next
N4 M400*35 ; expect: error:61 line number N4 out of sequence, expected N3; resend from N3
; a line number without a checksum, a checksum without a line number
N3 M400 ; expect: error:62
M400*121 ; expect: error:65
; wrong, malformed and out-of-range checksums
N3 M400*0 ; expect: error:60 checksum mismatch
N3 M400*abc ; expect: error:60
N3 M400*256 ; expect: error:60
N3 M400* ; expect: error:60
; the checksum covers ( ... ) comments as sent; a '*' or ';' inside them is comment text
N3 M400 (a*b; c)*84 ; expect: ok
; unframed lines pass when framing is optional, and do not advance the numbering
G90 ; expect: ok
N4 M105*35 ; expect: ok
N-5 M105*15 ; expect: error:27
N5.5 M105*57 ; expect: error:23
N5 ; expect: error:62
; a line whose checksum passes advances N whatever its command's fate (Marlin)
N5*123 ; expect: error:1
N5 M105*34 ; expect: error:61 line number N5 out of sequence, expected N6; resend from N6
N6 M105*33 ; expect: ok
N7 G2 X1*101 ; expect: error:20
N8 M105*47 ; expect: ok
