; tests/avr/realtime.gcode - a square without smoothing for the realtime
; checks of the whole-chip tests (feed hold / resume and soft reset mid-move).
G21 G90 G61
G0 X5 Y5
M3
G1 X35 Y5 F2400
G1 X35 Y25
G1 X5 Y25
G1 X5 Y5
M5
G0 X0 Y0
M2
