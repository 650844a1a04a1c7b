"""Design calculations of the boards: datasheet equations in code that prints the numbers.

One module per board (`psu`); run `scripts/py -m r2ptools.kicad.calc.<board>` for the table.
tests/test_hardware.py checks that the values each calculation assumes are the ones on the board.
"""
