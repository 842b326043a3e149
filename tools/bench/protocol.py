"""Protocol decoder throughput and corruption detection.

    python -m tools.bench.protocol [--frames N] [--corrupt N] [--json]

Figures, each beside a reference measured in the same run:
- incremental decoder (StreamDecoder, 4 KiB chunks) and bulk decoder (decode_samples to NumPy),
  in sample frames per second, as a ratio to a minimal split -> COBS -> CRC loop;
- both as a multiple of a saturated 921600-baud link (10 bits per byte on the UART);
- false accepts: corrupted frames that decode anyway, over --corrupt randomly damaged frames
  (bit flips, bursts, inserted and deleted bytes), beside the frames that were decodable
  before damage.
"""

from __future__ import annotations

import random
import sys

from cobs import cobs
from spectratac.protocol import StreamDecoder, crc32c, decode_samples, encode_frame
from spectratac.protocol.generated import messages

from tools.bench.benchlib import Figure, parser, report, side_by_side

LINK_BAUD = 921_600


def sample_stream(n: int, seed: int = 1) -> tuple[bytes, int]:
    rng = random.Random(seed)
    frames = [
        encode_frame(
            messages.Sample(
                sample_seq=i,
                t_start_us=(i * 50_000) & 0xFFFF_FFFF,
                t_end_us=(i * 50_000 + 50_000) & 0xFFFF_FFFF,
                counts=tuple(tuple(rng.randrange(65536) for _ in range(5)) for _ in range(3)),
            ),
            seq=i & 0xFFFF,
        )
        for i in range(n)
    ]
    return b"".join(frames), len(frames[0])


def minimal_loop(data: bytes) -> int:
    """Reference: the least a decoder must do per frame (split, COBS, CRC), nothing else."""
    ok = 0
    decode = cobs.decode
    for part in data.split(b"\x00"):
        if part and crc32c(decode(part)) == 0x48674BC7:
            ok += 1
    return ok


def incremental(data: bytes) -> int:
    decoder = StreamDecoder()
    n = 0
    for i in range(0, len(data), 4096):
        n += len(decoder.feed(data[i : i + 4096]))
    return n


def corrupt(frame: bytes, rng: random.Random) -> bytes:
    body = bytearray(frame[:-1])  # keep the delimiter so frames stay independent
    kind = rng.randrange(4)
    if kind == 0:  # 1..4 random bit flips
        for _ in range(rng.randint(1, 4)):
            i = rng.randrange(len(body))
            body[i] ^= 1 << rng.randrange(8)
    elif kind == 1:  # a burst of up to 8 random bytes
        i = rng.randrange(len(body))
        for j in range(i, min(i + rng.randint(1, 8), len(body))):
            body[j] = rng.randrange(256) if body[j] != 0xFF else 0x00
    elif kind == 2:
        body.insert(rng.randrange(1, len(body)), rng.randrange(256))
    else:
        del body[rng.randrange(len(body))]
    return bytes(body) + b"\x00"


def false_accepts(n: int, seed: int = 7) -> tuple[int, int, dict[str, object]]:
    """Corrupt n frames; return (accepted, originals decodable, decoder statistics)."""
    rng = random.Random(seed)
    base = [encode_frame(messages.Sample(sample_seq=i), seq=i) for i in range(1000)]
    decoder = StreamDecoder()
    accepted = 0
    batch: list[bytes] = []
    for i in range(n):
        original = base[i % len(base)]
        damaged = corrupt(original, rng)
        while damaged == original:  # a burst can rewrite a byte with itself
            damaged = corrupt(original, rng)
        batch.append(damaged)
        if len(batch) == 10_000:
            accepted += len(decoder.feed(b"".join(batch)))
            batch.clear()
    accepted += len(decoder.feed(b"".join(batch)))
    clean = len(StreamDecoder().feed(b"".join(base)))
    return accepted, clean, decoder.stats.as_dict()


def main() -> int:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=200_000, help="frames per throughput round")
    p.add_argument("--corrupt", type=int, default=1_000_000, help="corrupted frames to test")
    args = p.parse_args()
    data, frame_len = sample_stream(args.frames)
    n = args.frames
    link_fps = LINK_BAUD / 10 / frame_len
    assert incremental(data) == n and len(decode_samples(data).samples) == n == minimal_loop(data)

    def ref() -> int:
        return minimal_loop(data)

    inc, ref_a = side_by_side(lambda: incremental(data), ref)
    bulk, ref_b = side_by_side(lambda: len(decode_samples(data).samples), ref)
    accepted, clean, stats = false_accepts(args.corrupt)
    figures = [
        Figure("incremental decoder", inc, "frames/s", "split+COBS+CRC loop", ref_a, inc / ref_a),
        Figure("bulk decoder", bulk, "frames/s", "split+COBS+CRC loop", ref_b, bulk / ref_b),
        Figure(
            "incremental vs link",
            inc,
            "frames/s",
            f"{LINK_BAUD} Bd link",
            link_fps,
            inc / link_fps,
            {"frame_bytes": frame_len},
        ),
        Figure("bulk vs link", bulk, "frames/s", f"{LINK_BAUD} Bd link", link_fps, bulk / link_fps),
        Figure(
            "false accepts",
            accepted,
            "frames",
            "undamaged decodable",
            clean,
            accepted / clean,
            {"corrupted_frames": args.corrupt, "decoder": stats},
        ),
    ]
    report(figures, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
