"""The slot-path comparison (scripts/r2ptools/slotpath.py) that shows a change to an image left the
code from the slot timer to the HRT frame's request alone: it finds the bus task and the slot-path
functions, and it sees one changed instruction among them."""
import shutil
import subprocess

from r2ptools import slotpath

from conftest import ROOT

MOTOR = ROOT / "firmware" / "images" / "motor.elf"


def test_an_image_has_the_same_slot_path_as_itself_and_the_bus_task_is_in_it():
    same, insns, changed = slotpath.compare(str(MOTOR), str(MOTOR))
    assert changed == []
    bus = [b for b in slotpath.functions(str(MOTOR))["embassy_executor::raw::TaskStorage<F>::poll"]
           if slotpath.on_path("embassy_executor::raw::TaskStorage<F>::poll", [b])]
    assert len(bus) == 1, "the bus task"
    # slot_tick inlined into the bus task (3 600 instructions) or on the path on its own
    funcs = slotpath.functions(str(MOTOR))
    tick = [k for k in funcs if k.endswith("::slot_tick")]
    assert len(bus[0]) > 3000 or (tick and all(slotpath.on_path(k, funcs[k]) for k in tick)), tick
    assert same > 50 and insns > 3000 + 2000


def test_one_changed_instruction_on_the_slot_path_is_reported(tmp_path):
    nm = subprocess.run(["arm-none-eabi-nm", "-C", str(MOTOR)], capture_output=True, text=True,
                        check=True).stdout
    addr = next(int(line.split()[0], 16) for line in nm.splitlines()
                if line.endswith(" rtcan::cycle::SlotClock::state"))
    sections = subprocess.run(["arm-none-eabi-readelf", "-SW", str(MOTOR)], capture_output=True,
                              text=True, check=True).stdout
    text = next(line.split("]", 1)[1].split() for line in sections.splitlines() if " .text " in line)
    offset = addr - int(text[2], 16) + int(text[3], 16)
    patched = tmp_path / "motor.elf"
    shutil.copyfile(MOTOR, patched)
    data = bytearray(patched.read_bytes())
    data[offset + 2:offset + 4] = (0xBF00).to_bytes(2, "little")  # its second half-word: a nop
    patched.write_bytes(bytes(data))
    _, _, changed = slotpath.compare(str(MOTOR), str(patched))
    assert [c.split(": ")[0] for c in changed] == ["rtcan::cycle::SlotClock::state"], changed
    assert slotpath.main([str(MOTOR), str(patched)]) == 1
