; tests/avr/workload.gcode — what `make firmware` runs on each image to find
; the deepest stack (tests/targets/fwsize.py): every kind of line the engine
; handles, smoothing in tolerance mode, a G5 spline, a jog, pen changes,
; dwell, lines that must fail; realtime '?' reports are sent alongside.
$$
$I
$G
$#
G21 G90 G17
G64 P0.05
M5
G0 X10 Y10
M3
G1 X20 Y10 F3000
G1 X25 Y12
G1 X28 Y16
G1 X27 Y21
G1 X23 Y25
G1 X18 Y26
G1 X13 Y23
G5 I5 J0 P-5 Q0 X30 Y30
G5.1 I4 J4 X36 Y30
G4 P0.05
G61
G1 X5 Y5
M5
G91 G0 X1 Y1
G90
$J=G91 X2 Y-1 F1000
G1 X1000 F3000
G1 X1 X2
G92 X0 Y0
G0 X-6 Y-6
G92.1
G0 X0 Y0
M2
