"""How the motor module's sheet is drawn: power input and bridge on top, driver in the middle,
sensing and the encoder below, the core sheet's box on the right. Grid units of 2.54 mm.
The numbers in the notes are calc/motor.py's (`scripts/py -m r2ptools.kicad.calc.motor`)."""
from __future__ import annotations

from r2ptools.kicad.design import At, Block

DRAWING: dict[str, At] = {"sheet:core": At(132, 8)}

BLOCKS = [
    Block("Power input and bridge: 10-44 V, 20 A continuous, 30 A for 10 s", 4, 4, 120, 44, notes=[
        (6, 40, "F102 30 A: 20 A is 74 % of its 60 °C rating. D101 SMCJ45A: V_BR ≥ 50 V above the\n"
                "46.4-49.2 V trip, clamp 72.7 V < the driver's 80 V. Bulk 4 × 1000 µF 63 V: 10 A rms\n"
                "ripple at 20 A, d = 0.5 (2.49 A each ≤ 2.56 A); 8 × 2.2 µF 100 V close the loop."),
    ]),
    Block("Gate driver DRV8350H: 6x PWM, charge pump, VDS over-current, nFAULT", 4, 46, 80, 80, notes=[
        (6, 76, "VDS trip 0.2 V: 50-120 A (a short; the firmware trips overloads).\n"
                "Charge pump load 2 Q_g f = 4.7 mA; VCP droop 236 mV per turn-on."),
    ]),
    Block("Sensing: current, supply, over-voltage, encoder", 82, 46, 161, 112, notes=[
        (84, 108, "ACS725 ±30 A: 44 mV/A, 18.3 mA/count. VMOT_SENSE = VMOT / 16 (52.8 V full scale).\n"
                  "Trip: 1.242 V × (375 k + 10 k) / 10 k = 47.8 V → DRV_FAULT (TIM1_BKIN).\n"
                  "Encoder: 1 k / 100 pF = 1.6 MHz, 74LVC2G17 at 3.3 V (PA6/PA7 are not 5 V tolerant)."),
    ]),
]
