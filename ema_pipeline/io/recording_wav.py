"""WAV files (scipy) as the raw channels of a recording, the RIFF header checked
before any sample is decoded, for :func:`ema_pipeline.io.recording.read_recording`
(the rules: its module docstring).
"""

from __future__ import annotations

import os
import struct
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ema_pipeline.acquisition.channels import ChannelData, check_sample_rate, match_channel
from ema_pipeline.data import DataError
from ema_pipeline.io.files import open_regular

__all__ = ["MAX_WAV_CHANNELS", "read_wav_channels", "require_wav_settings", "wav_layout"]

#: Most channels a WAV recording may declare (a DAQ's 1024 channels; 65535 is a
#: damaged header).
MAX_WAV_CHANNELS = 1024


def wav_layout(path: str | os.PathLike[str]) -> tuple[int, int, int, int]:
    """(channels, sample rate in Hz, bytes per frame, frames) from the RIFF header of
    a WAV file, checked against the file before any sample is decoded: a DataError
    naming the file for a header cut short (``truncated WAV header``), no fmt or data
    chunk, 0 or more than :data:`MAX_WAV_CHANNELS` channels, a frame size that is not
    a whole number of bytes per channel, or a data chunk that declares more bytes
    than the file holds or not a whole number of frames (``truncated``, with the
    numbers). RIFF (little-endian), RIFX (big-endian) and RF64 (sizes in ``ds64``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from scipy.io import wavfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.wav"
    >>> wavfile.write(p, 2048, np.zeros((100, 2), dtype=np.int16))
    >>> wav_layout(p)
    (2, 2048, 4, 100)
    >>> _ = p.write_bytes(p.read_bytes()[:-40])  # 10 frames cut off
    >>> wav_layout(p)
    Traceback (most recent call last):
    ...
    ema_pipeline.data.DataError: ...a.wav: truncated WAV file: the data chunk declares 400
    bytes (100 frames of 2 channels) but the file holds 360 (90 frames)
    """
    path = Path(path)
    with open_regular(path, "a WAV file") as fh:
        raw = fh.read()
    if len(raw) < 12:
        raise DataError(f"{path}: truncated WAV header: {len(raw)} bytes, the RIFF header "
                        "alone has 12")
    kind = raw[:4]
    if kind not in (b"RIFF", b"RIFX", b"RF64") or raw[8:12] != b"WAVE":
        raise DataError(f"{path}: not a WAV file (no RIFF/WAVE header)")
    endian = ">" if kind == b"RIFX" else "<"
    pos, fmt, big_data = 12, None, None
    while True:
        if pos + 8 > len(raw):
            missing = "fmt" if fmt is None else "data"
            raise DataError(f"{path}: truncated WAV header: the file ends at byte {len(raw)} "
                            f"before its {missing} chunk")
        cid = raw[pos:pos + 4]
        (size,) = struct.unpack(endian + "I", raw[pos + 4:pos + 8])
        body = pos + 8
        if cid == b"ds64" and size >= 16:
            if body + 16 > len(raw):
                raise DataError(f"{path}: truncated WAV header: ds64 chunk cut at byte "
                                f"{len(raw)}")
            big_data = struct.unpack("<Q", raw[body + 8:body + 16])[0]
        elif cid == b"fmt ":
            if size < 16 or body + 16 > len(raw):
                raise DataError(f"{path}: truncated WAV header: fmt chunk of "
                                f"{min(size, len(raw) - body)} bytes, at least 16 expected")
            _, channels, rate, _, align, bits = struct.unpack(endian + "HHIIHH",
                                                             raw[body:body + 16])
            if not 1 <= channels <= MAX_WAV_CHANNELS:
                raise DataError(f"{path}: WAV header declares {channels} channels (1 to "
                                f"{MAX_WAV_CHANNELS} expected): a damaged header")
            if align == 0 or align % channels or bits == 0:
                raise DataError(f"{path}: WAV header: frames of {align} bytes for {channels} "
                                f"channels of {bits} bits are not whole samples: a damaged "
                                "header")
            fmt = (channels, rate, align)
        elif cid == b"data":
            if fmt is None:
                raise DataError(f"{path}: WAV data chunk before its fmt chunk")
            channels, rate, align = fmt
            if kind == b"RF64" and size == 0xFFFFFFFF and big_data is not None:
                size = big_data
            held = len(raw) - body
            if size > held:
                raise DataError(
                    f"{path}: truncated WAV file: the data chunk declares {size} bytes "
                    f"({size // align} frames of {channels} channels) but the file holds "
                    f"{held} ({held // align} frames)")
            if size % align:
                raise DataError(f"{path}: WAV data chunk of {size} bytes is not a whole "
                                f"number of {align}-byte frames: truncated or damaged")
            if size == 0:
                raise DataError(f"{path}: WAV file holds no samples (empty data chunk)")
            return channels, rate, align, size // align
        pos = body + size + (size & 1)  # chunks are padded to even sizes


def require_wav_settings(path: Path, channels: list[ChannelData],
                          scale: Mapping[str, float] | None,
                          units: Mapping[str, str] | None) -> None:
    """Every WAV channel needs a unit, and an integer one a scale (keys: name or
    position); float samples are taken as stored, in the unit."""
    names = [c.name for c in channels]
    for what, given in (("units", units), ("scale", scale)):
        covered = {match_channel(key, names, str(path), what) for key in (given or {})}
        missing = [n for k, n in enumerate(names) if k not in covered
                   and not (what == "scale" and channels[k].full_scale is None)]
        if missing:
            raise DataError(f"{path}: a WAV file holds no units: give {what} for channel(s) "
                            f"{', '.join(missing)} (e.g. --unit 0=N --unit 1=g --scale 0=500 "
                            "--scale 1=50)")


def read_wav_channels(path: Path) -> tuple[list[ChannelData], tuple[int, ...]]:
    """The channels of a WAV file (``0``, ``1``, ...), integer samples as fractions
    of full scale, float samples as stored; the header checked first
    (:func:`wav_layout`)."""
    from scipy.io import wavfile

    n_channels, header_rate, _, n_frames = wav_layout(path)  # refused before decoding
    check_sample_rate(header_rate, str(path), "WAV header")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", wavfile.WavFileWarning)
            rate, data = wavfile.read(path)
    except wavfile.WavFileWarning as exc:
        raise DataError(f"{path}: truncated or damaged WAV file ({exc})") from None
    except (ValueError, OSError, EOFError, IndexError, TypeError, struct.error,
            ZeroDivisionError) as exc:
        raise DataError(f"{path}: not a readable WAV file ({type(exc).__name__}: {exc})") \
            from None
    data = np.asarray(data)
    if data.ndim == 1:
        data = data[:, None]
    if data.shape != (n_frames, n_channels):
        raise DataError(f"{path}: WAV file decoded as {data.shape[0]} frames of "
                        f"{data.shape[1]} channels, its header says {n_frames} of {n_channels}")
    full: float | None = 1.0
    if data.dtype == np.uint8:
        values = (data.astype(float) - 128.0) / 128.0
    elif np.issubdtype(data.dtype, np.integer):
        values = data.astype(float) / float(2 ** (8 * data.dtype.itemsize - 1))
    else:
        values, full = data.astype(float), None
    channels = [ChannelData(name=str(k), data=values[:, k], sample_rate_hz=float(rate),
                            full_scale=full) for k in range(values.shape[1])]
    return channels, (0,)
