"""Frames from a video: decode at a chosen rate, keep the sharp frames that add a new view.

A 100 s clip at the paper's 25 fps gives 2,500 frames, most nearly identical; SfM time
grows with every one of them. A frame is kept when it is sharp compared with its
neighbours (variance of the Laplacian, a standard focus measure) and when the view has
moved enough since the last kept frame (median optical flow, as a fraction of the width).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from geostructure.errors import InputError

VIDEO_SUFFIXES = {".mp4", ".avi", ".mov", ".mkv", ".m4v", ".mts", ".webm"}


@dataclass(frozen=True)
class FrameOptions:
    fps: float | None = None  # decode rate; None: the video's own (the paper: 25)
    select: bool = True  # False: keep every decoded frame
    sharpness_ratio: float = 0.6  # drop a frame below this fraction of its neighbours' median
    min_motion: float = 0.012  # keep once the view moved this fraction of the width
    max_frames: int | None = None
    window: int = 9  # frames in the sharpness neighbourhood


@dataclass
class FrameReport:
    paths: list[Path]
    decoded: int
    blurred: int  # dropped: less sharp than their neighbours
    still: int  # dropped: too little motion since the last kept frame
    video_fps: float
    sample_fps: float
    times: list[float] = field(default_factory=list)

    def summary(self) -> str:
        return (
            f"kept {len(self.paths)} of {self.decoded} frames decoded at {self.sample_fps:g} fps "
            f"({self.blurred} blurred, {self.still} with too little motion)"
        )


def sharpness(gray: np.ndarray) -> float:
    """Variance of the Laplacian: high for crisp edges, low for motion or focus blur."""
    import cv2

    return float(cv2.Laplacian(gray, cv2.CV_64F).var())


def motion(previous: np.ndarray, current: np.ndarray) -> float:
    """Median optical-flow length between two small grey images, as a fraction of the width,
    over the textured half of the image (flat sky or wall says nothing about motion)."""
    import cv2

    flow = cv2.calcOpticalFlowFarneback(previous, current, None, 0.5, 4, 15, 3, 5, 1.2, 0)
    gy, gx = np.gradient(previous.astype(np.float32))
    gradient = np.hypot(gx, gy)
    textured = gradient >= np.median(gradient)
    return float(np.median(np.hypot(flow[..., 0], flow[..., 1])[textured])) / previous.shape[1]


def decode(video, fps: float | None = None):
    """Yield (time in s, BGR frame) at about ``fps`` (every frame when None)."""
    import av

    video = Path(video)
    try:
        container = av.open(str(video))
    except FileNotFoundError:
        raise InputError(f"{video}: no such file.") from None
    except (av.error.FFmpegError, ValueError) as exc:
        raise InputError(
            f"{video}: not a video that can be decoded ({exc.__class__.__name__}); "
            "give an mp4, avi or mov file, or a folder of photos."
        ) from None
    with container:
        if not container.streams.video:
            raise InputError(f"{video}: holds no video stream.")
        stream = container.streams.video[0]
        next_time = 0.0
        try:
            for frame in container.decode(stream):
                t = float(frame.time) if frame.time is not None else next_time
                if fps is None or t + 1e-6 >= next_time:
                    next_time = t + (1.0 / fps if fps else 0.0)
                    yield t, frame.to_ndarray(format="bgr24")
        except av.error.FFmpegError as exc:
            raise InputError(f"{video}: the video is damaged and stopped decoding ({exc}).") from None


def video_rate(video) -> float:
    import av

    try:
        with av.open(str(video)) as container:
            rate = container.streams.video[0].average_rate
            return float(rate) if rate else 25.0
    except (av.error.FFmpegError, IndexError, ValueError):
        raise InputError(
            f"{video}: not a video that can be decoded; give an mp4, avi or mov file, or a folder of photos."
        ) from None


def extract_frames(video, outdir, options: FrameOptions = FrameOptions(), progress=None) -> FrameReport:
    """Decode ``video`` and write the kept frames as ``frame_000123.jpg`` into ``outdir``.

    Streams: only a window of frames is held, so a long 4K clip fits in memory. A frame is
    judged once the ``window // 2`` frames after it have been decoded.
    """
    from collections import deque

    report = progress or (lambda stage, done, total: None)
    if not Path(video).is_file():
        raise InputError(
            f"{video}: no such file." if not Path(video).exists() else f"{video}: is a folder, not a video file."
        )
    video_fps = video_rate(video)
    sample_fps = min(options.fps or video_fps, video_fps)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    half = options.window // 2
    state = {"kept": [], "times": [], "blurred": 0, "still": 0, "last": None}
    buffer, scores, decoded = deque(), deque(maxlen=options.window), 0
    stream = _with_sharpness(decode(video, None if sample_fps >= video_fps else sample_fps), 160)
    for item in stream:
        decoded += 1
        buffer.append((decoded - 1, *item))
        scores.append(item[2])
        report("frames", decoded, None)
        if len(buffer) > half:
            if _judge(buffer.popleft(), scores, outdir, options, state):
                break
    while buffer and not (options.max_frames and len(state["kept"]) >= options.max_frames):
        _judge(buffer.popleft(), scores, outdir, options, state)
    if not decoded:
        raise InputError(f"{video}: holds no frames that could be decoded.")
    return FrameReport(state["kept"], decoded, state["blurred"], state["still"], video_fps, sample_fps, state["times"])


def _judge(frame, scores, outdir, options, state) -> bool:
    """Keep or drop one frame; True once ``max_frames`` are kept."""
    import cv2

    index, t, image, score, small = frame
    if options.select:
        if score < options.sharpness_ratio * np.median(scores):
            state["blurred"] += 1
            return False
        if state["last"] is not None and motion(state["last"], small) < options.min_motion:
            state["still"] += 1
            return False
    path = outdir / f"frame_{index:06d}.jpg"
    cv2.imwrite(str(path), image, [cv2.IMWRITE_JPEG_QUALITY, 95])
    state["kept"].append(path)
    state["times"].append(t)
    state["last"] = small
    return bool(options.max_frames and len(state["kept"]) >= options.max_frames)


def _with_sharpness(decoded, small_width):
    import cv2

    for t, image in decoded:
        gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        scale = small_width / gray.shape[1]
        small = cv2.resize(gray, (small_width, max(1, round(gray.shape[0] * scale))), interpolation=cv2.INTER_AREA)
        yield t, image, sharpness(gray), small
