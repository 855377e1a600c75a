"""What a circuit shows a controller over the HIL link (docs/protocol.md, SIGNALS and INPUTS packets): its
signals (every log column but time, SI) and its inputs, in wire order, and the fingerprint of both that every
packet carries (``layout``), so that both ends know they speak of the same circuit."""

from __future__ import annotations

import zlib

from hydrohil.circuits.run import input_unit, signal_units


# what one SIGNALS / INPUTS packet carries (hil/protocol.py computes the first from its datagram and checks it is
# this; protocol.h's HHIL_MAX_SIGNALS / HHIL_MAX_INPUTS the same)
LINK_MAX_SIGNALS, LINK_MAX_INPUTS = 176, 32


def check_link_size(signals, inputs, source: str = "circuit") -> None:
    """InputError when a circuit has more signals or inputs than a packet of the link carries."""
    from hydrohil.errors import InputError
    if len(signals) > LINK_MAX_SIGNALS or len(inputs) > LINK_MAX_INPUTS:
        raise InputError(f"a circuit's link carries at most {LINK_MAX_SIGNALS} signals and {LINK_MAX_INPUTS} inputs "
                         f"(this one: {len(signals)}, {len(inputs)})", source=source)


def wire_lists(c, lay) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """(name, SI unit) of a circuit's signals (its log columns but time) and of its inputs, in wire order
    (``lay``: its :class:`hydrohil.circuits.generate.Layout`)."""
    units = signal_units(c, lay)
    return [(name, units[name]) for name in lay.log_columns[1:]], [(name, input_unit(c, name)) for name in lay.inputs]


# a circuit plant's plant_log.csv (both plants): these columns, then every signal (SI), then every input as applied
PLANT_LOG_HEAD = ("k", "t", "wall", "jitter_us", "compute_us", "cmd_seq", "cmd_age", "watchdog", "status")
PLANT_LOG_INTS = ("k", "cmd_seq", "cmd_age", "watchdog", "status")


def plant_log_columns(signals, inputs) -> list[str]:
    """The columns of a circuit plant's plant_log.csv."""
    return [*PLANT_LOG_HEAD, *(n for n, _ in signals), *(f"{n}.applied" for n, _ in inputs)]


# the live panel's telemetry row of a circuit plant (hil/sidechannel.py; both ends make it from the circuit): the
# time, every signal, every input as applied, the step's timing and the watchdog; and of its controller
SIDE_TAIL = ("jitter_us", "compute_us", "watchdog")
CONTROLLER_SIDE_COLUMNS = ("reference", "measured", "command")


def side_columns(signals, inputs) -> tuple[str, ...]:
    """The telemetry columns of a circuit plant's side channel."""
    return ("t", *(n for n, _ in signals), *(f"{n}.applied" for n, _ in inputs), *SIDE_TAIL)


def circuit_link(c, lay=None) -> tuple[list[tuple[str, str]], list[tuple[str, str]], int]:
    """A circuit's signals and inputs in wire order and their layout (``lay``: its Layout when the caller has it;
    else the circuit is compiled, or loaded)."""
    if lay is None:
        from hydrohil.circuits.build import compile_circuit
        lay = compile_circuit(c).layout
    signals, inputs = wire_lists(c, lay)
    return signals, inputs, layout_id(signals, inputs)


def layout_id(signals, inputs) -> int:
    """CRC-32 (zlib) of the UTF-8 text ``signals:`` + one ``\\nname [unit]`` per signal + ``\\ninputs:`` + one
    ``\\nname [unit]`` per input."""
    text = "signals:" + "".join(f"\n{n} [{u}]" for n, u in signals) + "\ninputs:" + "".join(
        f"\n{n} [{u}]" for n, u in inputs)
    return zlib.crc32(text.encode())
