"""Is a recording's codec biasing λ? The codec, its settings and a measured frozen-motion share.

Lossy video biases the decay rate λ upwards: the encoder spends few bits where
a marker moves a few hundredths of a pixel per frame, so late in the decay the
decoded marker lags or stays put, the tracked amplitude falls faster than the
true one, and the fitted decay is too fast. The quantisation dead zone is a
small part of it: on a simulated GelSight trial (x264 ``fast``, CRF 18) the
tracked/true motion gain of the B-frames fell from 0.94 at 0.8 px to 0.69 at
0.18 px while the P-frames kept 0.97-0.99, and turning off B-frames or the
macroblock tree cut the λ bias more than turning off the dead zone
(``benchmarks/extraction/codec_bias.py``; ``benchmarks/RESULTS.md``, "codec_bias").

:func:`check_codec` combines three clues into a :class:`CodecCheck`:

- the **codec** of every source (``io.frames.video_info``; an image folder's
  image format) and whether it is lossless;
- for H.264 from x264, the **encoder settings** x264 writes into the stream
  (``crf``, ``deadzone``, ``bframes``, ...; :func:`x264_settings`);
- the **frozen-step share**, measured on the tracks (:func:`frozen_steps`):
  of the frame-to-frame steps of the most moving markers, the share that is
  exactly zero while another of those markers moved in the same frame. Sensor
  noise makes that share 0 on lossless video; a codec that skips or copies
  blocks makes it positive.

The warning follows the measurement: ``at_risk`` is set when lossy video
freezes the motion (frozen-step share over :data:`FROZEN_SHARE_RISK`); only when
the share cannot be measured (no moving markers counted) do the codec's settings
decide alone (their expected bias over :data:`BIAS_RISK`). So video that keeps the
sub-pixel motion (the simulator's H.264 without x264's dead zone: 0.0 % frozen, λ
within 1 %) is not flagged, and x264 with its defaults at CRF 23 is.
``expected_lambda_bias`` is the median λ bias the benchmark measured for that
codec and quality (NaN when unknown) when the motion freezes or cannot be judged,
and 0 when the measurement shows it kept.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from liquidtouch.io.frames import image_files, video_info
from liquidtouch.signal.tactile import DEFAULT_N_MARKERS
from liquidtouch.tracking.tracks import MarkerTracks

#: codecs (FFmpeg names; image folders by format) that store frames without loss
LOSSLESS_CODECS = frozenset(
    {"ffv1", "png", "apng", "bmp", "tiff", "rawvideo", "huffyuv", "ffvhuff", "utvideo",
     "magicyuv", "qtrle", "r210", "v210", "zlib", "lagarith"}
)  # fmt: skip
#: image folders: codec by image suffix
IMAGE_CODECS = {".png": "png", ".bmp": "bmp", ".tif": "tiff", ".tiff": "tiff",
                ".jpg": "mjpeg", ".jpeg": "mjpeg"}  # fmt: skip
#: frozen-step share above which motion is considered frozen (lossless video: 0)
FROZEN_SHARE_RISK = 0.01
#: expected λ bias above which a recording is flagged
BIAS_RISK = 0.05
#: median λ bias vs lossless of the same frames (benchmarks/extraction/codec_bias.py, 4
#: simulated trials, λ 0.14-3.4 /s; x264's defaults, ``fast`` preset), by CRF; interpolated
#: linearly in CRF and flat beyond the ends (below CRF 18 it is an upper bound: not measured)
X264_CRF_BIAS = ((18, 0.25), (23, 0.34), (28, 0.47))
#: median λ bias of other lossy codecs as OpenCV's VideoWriter writes them (same benchmark):
#: MPEG-4 Part 2 (``mp4v``) +19 %; MJPEG at OpenCV's quality 95 +0.7 % (intra-only: no
#: frame is predicted from another, nothing freezes)
CODEC_BIAS = {"mpeg4": 0.19, "mjpeg": 0.007}
#: bytes of a stream searched for x264's settings (they come with the first frame)
X264_SEARCH_BYTES = 1 << 16


@dataclass(frozen=True)
class CodecCheck:
    """The codec diagnostic of one extraction (module docstring).

    ``codec``: the sources' codecs joined by ``,`` (``""`` for imported tracks);
    ``lossless``: True when every source is lossless, False when one is lossy,
    None when unknown; ``encoder``: x264's settings when found (name → value);
    ``frozen_step_share``: share of frozen steps of moving markers (0–1);
    ``freezing_step_px``: median per-frame motion [px] of the other moving
    markers when a marker froze (NaN when none froze); ``expected_lambda_bias``:
    relative λ bias the benchmark measured for this codec and quality (NaN unknown);
    ``at_risk``: the fitted λ is likely biased upwards by the codec.
    """

    codec: str
    lossless: bool | None
    frozen_step_share: float
    freezing_step_px: float
    expected_lambda_bias: float
    at_risk: bool
    encoder: dict[str, str] = field(default_factory=dict)

    def warning(self) -> str | None:
        """One line for the user when :attr:`at_risk`, else None."""
        if not self.at_risk:
            return None
        bias = (
            f"λ is expected to come out ~{self.expected_lambda_bias:+.0%} too high"
            if math.isfinite(self.expected_lambda_bias)
            else "λ is likely biased upwards"
        )
        crf = f" CRF {self.encoder['crf']}" if "crf" in self.encoder else ""
        return (
            f"lossy video ({self.codec or 'unknown codec'}{crf}): "
            f"{self.frozen_step_share:.1%} of the moving markers' frame steps are frozen; "
            f"{bias}. Record losslessly (FFV1, PNG) for λ; ω is unaffected"
        )

    def to_dict(self) -> dict[str, object]:
        """JSON-ready: every field (``encoder`` only its ``crf`` when known)."""
        return {
            "codec": self.codec,
            "codec_lossless": self.lossless,
            "codec_crf": self.encoder.get("crf"),
            "frozen_step_share": self.frozen_step_share,
            "freezing_step_px": self.freezing_step_px,
            "codec_lambda_bias": self.expected_lambda_bias,
            "codec_at_risk": self.at_risk,
        }


def source_codec(path: str | Path) -> str:
    """FFmpeg codec name of a video file, or the image format of an image folder."""

    path = Path(path)
    if path.is_dir():
        files = image_files(path)
        return IMAGE_CODECS.get(files[0].suffix.lower(), files[0].suffix.lower().lstrip("."))
    return video_info(path).codec


def x264_settings(path: str | Path) -> dict[str, str]:
    """The options x264 wrote into an H.264 stream (``{"crf": "18.0", "deadzone": "21,11", ...}``).

    x264 stores its version and every option as text in the first frame's SEI;
    ``{}`` when the file is not H.264 from x264 (or cannot be read).
    """
    import av

    try:
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            seen = b""
            for packet in container.demux(stream):
                seen += bytes(packet)
                if b"x264 - core" in seen or len(seen) > X264_SEARCH_BYTES:
                    break
    except (av.FFmpegError, IndexError, OSError):
        return {}
    start = seen.find(b"x264 - core")
    if start < 0:
        return {}
    text = seen[start : start + 4096].split(b"\0", 1)[0].decode("ascii", "replace")
    options = text.split("options:", 1)[-1]
    return dict(re.findall(r"([\w-]+)=(\S+)", options))


def frozen_steps(
    tracks: Sequence[MarkerTracks], n_markers: int = DEFAULT_N_MARKERS
) -> tuple[float, float]:
    """``(share, step_px)``: frozen frame steps of the ``n_markers`` most moving markers.

    A step (frame k → k+1 of one marker, valid in both) is frozen when the
    marker's position did not change at all while at least one other selected
    marker of the same sensor moved (a frame repeated as a whole is not
    counted). ``share`` is frozen / counted steps (NaN when nothing was
    counted); ``step_px`` the median per-frame motion [px] of the moving
    selected markers in the frames where one froze (NaN when none froze).
    """
    per_sensor = max(1, math.ceil(n_markers / max(len(tracks), 1)))
    frozen = counted = 0
    levels = []
    for tr in tracks:
        if len(tr.t) < 2 or tr.n_markers < 2:
            continue
        disp = np.where(tr.valid[..., None], tr.displacement, np.nan)
        with np.errstate(invalid="ignore"):
            motion = np.nan_to_num(np.nanstd(np.linalg.norm(disp, axis=-1), axis=0))
        top = np.argsort(-motion, kind="stable")[:per_sensor]
        step = np.diff(tr.positions[:, top], axis=0)
        ok = tr.valid[1:, top] & tr.valid[:-1, top]
        size = np.where(ok, np.hypot(step[..., 0], step[..., 1]), np.nan)
        still = ok & (size == 0)
        moving = ok & (size > 0)
        # a step counts only when another selected marker moved in that frame
        others_moving = moving.sum(axis=1, keepdims=True) - moving > 0
        count = ok & others_moving
        frozen += int((still & count).sum())
        counted += int(count.sum())
        rows = np.flatnonzero((still & count).any(axis=1))
        if len(rows):
            with np.errstate(invalid="ignore"):
                levels.append(np.nanmedian(np.where(moving[rows], size[rows], np.nan), axis=1))
    share = frozen / counted if counted else math.nan
    level = float(np.median(np.concatenate(levels))) if levels else math.nan
    return share, level


def expected_lambda_bias(codec: str, encoder: dict[str, str] | None = None) -> float:
    """Median relative λ bias the benchmark measured for ``codec`` (and x264's CRF); NaN unknown."""
    encoder = encoder or {}
    if codec in LOSSLESS_CODECS or _x264_lossless(encoder):
        return 0.0
    if codec == "h264" and "crf" in encoder:
        crf, bias = np.array(X264_CRF_BIAS, dtype=float).T
        return float(np.interp(float(encoder["crf"]), crf, bias))
    if codec == "h264":
        return float(dict(X264_CRF_BIAS)[23])  # ffmpeg's default CRF
    return CODEC_BIAS.get(codec, math.nan)


def _x264_lossless(encoder: dict[str, str]) -> bool:
    """x264 at ``qp=0`` (or ``crf=0``) stores 4:2:0 luma without loss."""
    return (encoder.get("rc") == "cqp" and encoder.get("qp") == "0") or encoder.get("crf") == "0.0"


def check_codec(
    tracks: Sequence[MarkerTracks],
    sources: Sequence[str | Path] = (),
    n_markers: int = DEFAULT_N_MARKERS,
) -> CodecCheck:
    """The :class:`CodecCheck` of ``tracks`` tracked from ``sources`` (none: imported tracks)."""
    codecs, encoder = [], {}
    for source in sources:
        codec = source_codec(source)
        codecs.append(codec)
        if codec == "h264" and not encoder:
            encoder = x264_settings(source)
    share, level = frozen_steps(tracks, n_markers)
    if codecs:
        lossless: bool | None = all(
            c in LOSSLESS_CODECS or (c == "h264" and _x264_lossless(encoder)) for c in codecs
        )
        biases = [expected_lambda_bias(c, encoder) for c in codecs]
        bias = max(biases) if not all(math.isnan(b) for b in biases) else math.nan
    else:
        lossless, bias = None, math.nan
    if math.isfinite(share):  # the measurement decides
        at_risk = lossless is not True and share > FROZEN_SHARE_RISK
        if lossless is not True and not at_risk:
            bias = 0.0  # the motion is kept: the benchmark's codec bias does not apply
    else:  # nothing measured: the codec's settings alone
        at_risk = lossless is not True and math.isfinite(bias) and bias > BIAS_RISK
    return CodecCheck(
        codec=",".join(dict.fromkeys(codecs)),
        lossless=lossless,
        frozen_step_share=float(share),
        freezing_step_px=float(level),
        expected_lambda_bias=float(bias),
        at_risk=bool(at_risk),
        encoder=encoder,
    )
