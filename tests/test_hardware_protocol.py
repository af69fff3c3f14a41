"""The line protocol: CRC, framing, and the Python device (as a relay board) against the firmware's shared vectors."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from spherestep.errors import InputError
from spherestep.hardware import CurrentDevice, protocol
from spherestep.hardware.protocol import Frame, FrameError, LineReader, crc16, decode, encode

VECTORS = Path(__file__).resolve().parents[1] / "firmware" / "test" / "vectors.txt"


def test_crc16_check_values():
    # CRC-16/CCITT-FALSE check value from the CRC catalogue, and the worked example of docs/protocol.md
    assert crc16(b"123456789") == 0x29B1
    assert crc16(b"00,HELLO,1") == 0x5AA7
    assert crc16(b"") == 0xFFFF


def test_encode_is_the_documented_frame():
    assert encode(0, "HELLO", 1) == b"$00,HELLO,1*5AA7\n"
    assert encode(None, "NAK", "CRC").startswith(b"$--,NAK,CRC*")
    assert encode(0x1A5, "PING")[:3] == b"$A5"  # sequence numbers wrap at 256


_FIELD = st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_.-", min_size=1, max_size=8)


@given(seq=st.one_of(st.none(), st.integers(0, 255)), verb=_FIELD, args=st.lists(_FIELD, max_size=5))
def test_decode_inverts_encode(seq, verb, args):
    line = encode(seq, verb, *args)
    assert decode(line[1:-1]) == Frame(seq, verb, tuple(args))


@given(seq=st.integers(0, 255), enable=st.integers(0, 2**32 - 1), polarity=st.integers(0, 2**32 - 1),
       data=st.data())
def test_no_single_bit_error_changes_a_frame(seq, enable, polarity, data):
    body = encode(seq, "SET", protocol.format_mask(enable), protocol.format_mask(polarity))[1:-1]
    i = data.draw(st.integers(0, len(body) - 1))
    bit = data.draw(st.integers(0, 7))
    damaged = body[:i] + bytes([body[i] ^ (1 << bit)]) + body[i + 1:]
    try:
        frame = decode(damaged)
    except FrameError as err:
        assert err.code in protocol.RETRYABLE
    else:  # only a letter of the checksum changing case (bit 5) reads the same
        assert i > len(body) - 5 and bit == 5 and frame == decode(body)


def test_decode_rejections_name_their_code():
    good = encode(5, "SET", "3", "0")[1:-1]
    assert decode(good) == Frame(5, "SET", ("3", "0"))
    lower = b"0a,SET,ff,0"
    assert decode(lower + b"*" + f"{crc16(lower):04x}".encode()) == Frame(10, "SET", ("ff", "0"))  # hex any case
    for bad, code in [(good[:-5], "FRAME"), (good[:-1], "FRAME"), (good[:-4] + b"00000", "FRAME"),
                      (good[:-4] + b"0000", "CRC"), (b"\x01" + good, "FRAME"), (b"X" * 81, "FRAME")]:
        with pytest.raises(FrameError) as err:
            decode(bad)
        assert err.value.code == code, bad


def test_line_reader_resynchronises_on_dollar():
    reader = LineReader()
    assert reader.feed(b"noise\n$00,PI") == []
    assert reader.feed(b"NG*0000\r\n$01,A$02,B*1234\n") == [b"00,PING*0000", b"02,B*1234"]
    assert reader.feed(b"$" + b"X" * 200 + b"\n") == [b"X" * 81]  # kept just long enough to be rejected


def test_format_mask_is_canonical_hex():
    assert protocol.format_mask(0) == "0"
    assert protocol.format_mask(0x80000000) == "80000000"
    with pytest.raises(ValueError):
        protocol.format_mask(-1)
    assert protocol.parse_hex("0x1F", 1, 16) is None and protocol.parse_hex(" 1", 1, 16) is None
    assert protocol.parse_hex("00ff", 1, 16) == 255


def _unescape(text: str) -> bytes:
    return re.sub(r"\\(x[0-9A-Fa-f]{2}|.)", lambda m: chr(int(m[1][1:], 16)) if m[1][0] == "x"
                  else {"n": "\n", "r": "\r"}.get(m[1], m[1]), text).encode("latin-1")


def test_relay_board_passes_the_firmware_vectors():
    """Every line of firmware/test/vectors.txt, as the C++ harness runs it (tests/test_firmware.py), against the
    device as a relay board (its clock in µs: the vectors' ms × 1000)."""
    board, now, replies, checked = None, 0, [], 0
    for number, line in enumerate(VECTORS.read_text().splitlines(), 1):
        if not line or line.startswith("#"):
            continue
        where = f"vectors.txt:{number}: {line}"
        op, _, rest = line.partition(" ")
        if op == "crc":
            text, expected = rest.split()
            assert f"{crc16(text.encode()):X}" == expected, where
        elif op == "device":
            channels, watchdog, name = rest.split()
            board, now, replies = CurrentDevice.relay_board(int(channels), int(watchdog), name), 0, []
        elif op == "@":
            now = 1000 * int(rest)
            board.tick(now)
        elif op in (">", ">raw"):
            assert not replies, f"{where}: a reply to the previous send was not checked: {replies}"
            data = b"$" + rest.encode() + b"*" + f"{crc16(rest.encode()):04X}".encode() + b"\n" if op == ">" \
                else _unescape(rest)
            replies = [b"$" + r for r in LineReader().feed(board.receive(data, now))]
        elif op == "<":
            expected = b"$" + rest.encode() + b"*" + f"{crc16(rest.encode()):04X}".encode()
            assert replies and replies.pop(0) == expected, where
        elif op == "-":
            assert not replies, where
        elif op == "=":
            enable, polarity = (int(v, 16) for v in rest.split())
            assert (board.enable, board.polarity) == (enable, polarity), where
        else:
            raise AssertionError(f"{where}: unknown operation")
        checked += 1
    assert checked > 100


def test_relay_board_switches_polarity_only_with_enables_open():
    emu = CurrentDevice.relay_board(channels=8, watchdog_ms=500, name="bbm")
    for seq, body in enumerate(["HELLO,1", "SET,3,0", "SET,3,2", "SET,5,2", "OFF"]):
        emu.receive(encode(seq, *body.split(",")), 0)
    assert list(emu.trace)[2:] == [("enable", 0), ("polarity", 0),  # HELLO: all off
                                   ("enable", 3),  # SET 3,0
                                   ("enable", 0), ("polarity", 2), ("enable", 3),  # SET 3,2: break, switch, make
                                   ("enable", 5),  # SET 5,2: polarity unchanged
                                   ("enable", 0), ("polarity", 0)]  # OFF
    enabled = 0
    for kind, mask in emu.trace:
        assert kind == "enable" or enabled == 0
        enabled = mask if kind == "enable" else enabled


@pytest.mark.parametrize("kwargs, field", [({"channels": 0}, "channels"), ({"channels": 65}, "channels"),
                                           ({"watchdog_ms": 0}, "watchdog_ms"), ({"name": "a,b"}, "name"),
                                           ({"name": ""}, "name")])
def test_relay_board_rejects_bad_configuration(kwargs, field):
    with pytest.raises(InputError, match=f"^{field} must be"):
        CurrentDevice.relay_board(**kwargs)


def test_the_relay_board_is_the_device_without_bridges():
    """One device class: the relay board speaks protocol 1 only (no DRIVE, no version 2), with 80-byte frames,
    no current limit (every relay may close) and no CRCS trip; the same class with bridges speaks both."""
    board = CurrentDevice.relay_board(channels=8, watchdog_ms=500, name="relays")
    assert (board.channels, board.versions, board.bridges) == (8, (1,), None)
    assert board.receive(encode(1, "HELLO", 2), 0) == encode(1, "NAK", "VERSION")
    assert board.receive(encode(2, "DRIVE", "0"), 0) == encode(2, "NAK", "VERB")  # an unknown verb, not SESSION
    assert board.receive(encode(3, "HELLO", 1), 0) == encode(3, "ACK", "HELLO", 1, 8, 500, "relays")
    assert board.receive(encode(4, "SET", "FF", "F0"), 0) == encode(4, "ACK", "SET", "FF", "F0")
    assert board.receive(encode(5, "READ"), 0) == encode(5, "NAK", "VERB")
    for k in range(12):  # a storm of damaged frames: NAK each, the session and the relays kept
        assert board.receive(b"$06,PING*0000\n", 1000 * k) == encode(None, "NAK", "CRC")
    assert board.session and (board.enable, board.polarity) == (0xFF, 0xF0) and board.trips == []
    assert board.receive(encode(7, "PING"), 600_000) == encode(7, "NAK", "WDOG")  # 500 ms without a command
    assert [code for code, _, _ in board.trips] == ["WDOG"] and (board.enable, board.polarity) == (0, 0)
    assert board.off_us == 600_000  # the relays went from driven to off then


@pytest.mark.parametrize("args, kwargs, field", [((None, 3, 1), {}, "bridges"),
                                                 ((object(), 0, 0), {"relays": 8}, "relays"),
                                                 ((None, 2, 0), {"relays": 8}, "relays"),
                                                 ((None, 0, 0), {"relays": 65}, "channels")])
def test_a_device_is_bridges_or_relays(args, kwargs, field):
    with pytest.raises(InputError, match=f"^{field} must be"):
        CurrentDevice(*args, **kwargs)
