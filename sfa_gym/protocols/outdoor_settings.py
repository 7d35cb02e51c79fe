"""The outdoor protocol's settings (:class:`Config`) and the env of each of its runs: the drive
and the test runs of the appearance conditions, at the world's time, date and day.

The clock: the drive starts at ``start_hour``; the test runs start when the drive's test part
does (the training frames later), ``later`` that many ``later_hours`` after it. The sun is the
world's own (a sine arc over the day) unless a ``day_of_year`` (and ``latitude_deg``) dates it
(:mod:`sfa_gym.sim.worlds.sun`). The weather and mover ``day`` of the drive is the world's
unless given; ``other_day`` is ``other_days`` after it. Several ``later_hours`` or
``other_days`` give one condition each (``later+2h``, ``later+6h``; ``other_day+1``, ...), a
single one keeps the plain name (``later``, ``other_day``) and the runs of before.
``rearranged`` is the drive's day with the parked objects of the next arrangement day (cars
that left or came, bins, benches, a building-site fence: :mod:`sfa_gym.sim.worlds.rearrange`)
and nothing else changed; ``other_day`` changes the clouds and movers only. ``other_season``
(a dated drive only) is the test path ``season_days`` later in the year at the same hour: the
sun of that date and, with ``seasons``, the trees' foliage (several: ``other_season+92d``, ...).
``wet`` and ``snow`` are the drive's day and hour with the ground wet after rain or under snow
(the asphalt cleared to wet slush; :mod:`sfa_gym.sim.worlds.ground`), nothing else changed.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, get_args

from sfa_gym._checks import check_int, check_int_in, check_positive_int, is_number
from sfa_gym.localization.appearance import Normalisation
from sfa_gym.protocols.settings import check_choice, check_choices
from sfa_gym.rotation import Rotation, check_step
from sfa_gym.sim.camera.fog import check_visibility
from sfa_gym.sim.worlds.sun import check_day_of_year, check_latitude

__all__ = ["CONDITIONS", "ENV_ID", "Camera", "Condition", "Config"]

ENV_ID = "sfa_gym/OmniRoverOutdoor-v0"
"""The env every outdoor run is rendered in."""
Condition = Literal[
    "after",
    "later",
    "overcast",
    "no_movers",
    "other_day",
    "fog",
    "rearranged",
    "other_season",
    "wet",
    "snow",
]
CONDITIONS: tuple[str, ...] = get_args(Condition)
"""The kinds of test condition (see the module docstring); ``later`` and ``other_day`` give one
condition per offset when their offsets are a tuple (:meth:`Config.test_conditions`)."""
Camera = Literal["mirror", "cylindrical"]
TrainAlsoOrder = Literal["frames", "rotations"]


@dataclass(frozen=True)
class Config:
    """Settings of the outdoor protocol (defaults: the paper's)."""

    panorama: tuple[int, int] | None = None
    """(height, width) of the panoramas in pixels (quick runs); None: the paper's 60 x 600"""
    train_frames: int = 5900
    """frames of the training run (the paper: 5900)"""
    test_frames: int = 2800
    """frames of the test run (the paper: 2800)"""
    frame_dt: float = 0.1
    """seconds between frames (the env's control period); longer periods give short test
    runs over the same paths"""
    spacing: float = 0.5
    """training run: distance between the grid's lanes, m (larger for short runs)"""
    test_spacing: float = 1.0
    """test run: distance between the grid's lanes, m"""
    start_hour: float = 10.0
    """time of day at which the training run starts, hours (local solar time with day_of_year)"""
    day_of_year: int | None = None
    """the date of the sun's path, 1..366 (15: mid-January, 196: mid-July), at latitude_deg;
    None: the world's own sun (rises 6:00, 55 degrees high at 13:00, sets 20:00)"""
    latitude_deg: float | None = None
    """the latitude of the dated sun, degrees north (only with day_of_year; None: 50)"""
    seasons: bool = False
    """the trees' foliage by the date (only with day_of_year): leaf-out, autumn colours, bare
    crowns in winter (sfa_gym.sim.worlds.seasons); False: the crowns as drawn"""
    grass_seasons: bool = False
    """the lawn's colour by the date (only with day_of_year): green from May to October,
    dormant straw-olive in winter (sfa_gym.sim.worlds.ground); False: the lawn as drawn"""
    shadows: bool = False
    """the sun's cast shadows, moving with the clock (sfa_gym.sim.camera.shadows; about twice
    the rendering time)"""
    cloud_cover: float | None = None
    """clouds drawn into the sky covering this fraction of it, for each run's start hour and
    day (sfa_gym.sim.worlds.sky); None: the plain gradient sky"""
    day: int | None = None
    """the weather and mover day (clouds, schedules) of the drive and of every test run but
    other_day; None: the world's own (day 0)"""
    conditions: tuple[Condition, ...] = ("after",)
    """test conditions scored (appearance tracks): after, later, overcast, no_movers,
    other_day, fog, rearranged, other_season, wet (the ground wet after rain), snow (snow
    lying, the asphalt cleared); "after" is scored always, a track's score is the mean over
    these"""
    later_hours: float | tuple[float, ...] = 4.0
    """the "later" test run starts this many hours after the "after" one; several
    (--later-hours 2 6): one condition each, named later+2h, later+6h"""
    other_days: int | tuple[int, ...] = 1
    """the "other_day" test run is this many days after the drive's day (other clouds and
    schedules, the same date); several (--other-days 1 2): one condition each, named
    other_day+1, other_day+2"""
    season_days: int | tuple[int, ...] = 92
    """the "other_season" test run is this many days later in the year than the drive (a
    dated drive: day_of_year), at the same hour; several (--season-days 92 183): one condition
    each, named other_season+92d, other_season+183d"""
    fog_visibility_m: float = 100.0
    """the "fog" test run: an overcast day (thick fog hides the sun) seen through fog of this
    meteorological visibility, m (thick fog: 50-200; sfa_gym.sim.camera.fog)"""
    dynamics: bool = True
    """the world's dynamics (sun, clouds, movers); False: a static world (ablation)"""
    sensor: bool = True
    """the camera's auto-exposure and pixel noise"""
    white_balance: bool = False
    """the camera's auto white balance too (sfa_gym.sim.camera.sensor.SensorSpec; needs sensor)"""
    vignetting: float = 0.0
    """share of the light the mirror camera's lens loses at the mirror's rim, in [0, 1) (0:
    none; needs sensor and the mirror camera)"""
    exposure_s: float = 0.0
    """the camera's exposure time at unit gain, s (the auto-exposure lengthens it): frames
    blur while the rover turns (sfa_gym.sim.camera.sensor; needs sensor); 0: instantaneous"""
    vibration: bool = True
    """the sprung camera mast (False: a rigid one)"""
    textures: bool = False
    """generated textures on the ground, facades, trees and bushes (sfa_gym.sim.worlds.textures:
    the env's textures=True); False: the flat-shaded world"""
    camera: Camera = "mirror"
    """the mirror camera (unwarped) or the ideal cylindrical one"""
    step: int = 5
    """simulated rotation step, columns (must divide the panorama width)"""
    eval_rotations: int | None = 12
    """evenly spread rotation windows per frame (12: every 30 degrees) whose features every
    regression is fitted on and averages over; None: all (120 at 600 px: slow for plug-ins
    that transform every view; SFA's estimate over all 120 is reported beside)"""
    normalise: Normalisation = "none"
    """input normalisation of every panorama, for every method (sfa_gym.localization.appearance:
    none, grey_world, log_gradient)"""
    train_also: tuple[float, ...] = ()
    """levers: the training path driven again, starting this many hours after start_hour, each
    such run interleaved frame by frame with the training run (the appearance of a place then
    changes faster than the place); every method trains on all of them"""
    train_also_order: TrainAlsoOrder = "frames"
    """where the train_also runs change the appearance: "frames" (each frame's rotations under
    one run, the next frame under the next run) or "rotations" (each rotation of a frame under
    every run before the next rotation: the appearance changes inside the frame's rotation
    sequence, faster than the rotation)"""
    fit_every: int = 5
    """plug-ins without a rotation shortcut are fitted on every n-th training frame"""
    seed: int = 0
    """seed of the env resets (sensor noise) and of the path planner"""

    @property
    def rotation(self) -> Rotation:
        """The simulated rotation every method is trained and evaluated on."""
        return Rotation(step=self.step)

    @property
    def appearances(self) -> int:
        """Training panoramas per location inside a rotation sequence (1 + the train_also runs
        with ``train_also_order="rotations"``, else 1)."""
        return 1 + len(self.train_also) if self.train_also_order == "rotations" else 1

    def validate(self) -> None:
        """Raise ValueError (or TypeError) naming the first bad setting."""
        check_int("seed", self.seed)
        for name in ("train_frames", "test_frames"):
            if check_positive_int(name, getattr(self, name)) < 10:
                raise ValueError(f"{name} must be >= 10, got {getattr(self, name)!r}")
        for name in ("step", "fit_every"):
            check_positive_int(name, getattr(self, name))
        if self.eval_rotations is not None:
            check_positive_int("eval_rotations", self.eval_rotations)
        for name, unit in (
            ("frame_dt", "seconds"),
            ("spacing", "metres"),
            ("test_spacing", "metres"),
        ):
            value = getattr(self, name)
            if not is_number(value) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a positive number of {unit}, got {value!r}")
        if not is_number(self.start_hour) or not math.isfinite(self.start_hour):
            raise ValueError(
                f"start_hour must be a finite number of hours, got {self.start_hour!r}"
            )
        if not 0.0 <= self.start_hour < 24.0:
            raise ValueError(f"start_hour must lie in [0, 24) hours, got {self.start_hour!r}")
        check_choices("conditions", self.conditions, Condition, "a condition")
        check_visibility(self.fog_visibility_m)
        if not self.dynamics and set(self.conditions) - {"after"}:
            raise ValueError(
                f"conditions {sorted(set(self.conditions) - {'after'})} change the dynamics; "
                "they need dynamics=True"
            )
        self._validate_clock()
        switches = (
            "dynamics",
            "sensor",
            "vibration",
            "textures",
            "white_balance",
            "seasons",
            "grass_seasons",
        )
        for name in (*switches, "shadows"):
            if not isinstance(getattr(self, name), bool):
                raise TypeError(f"{name} must be True or False, got {getattr(self, name)!r}")
        cover = self.cloud_cover
        if cover is not None and not (is_number(cover) and 0.0 <= cover <= 1.0):
            raise ValueError(f"cloud_cover must be None or lie in [0, 1], got {cover!r}")
        self._sensor_spec()  # the sensor's own check of vignetting and exposure_s
        if self._sensor_effects and not self.sensor:
            raise ValueError(
                "white_balance, vignetting and exposure_s are effects of the sensor: sensor=True"
            )
        if self.vignetting and self.camera != "mirror":
            raise ValueError(
                f"vignetting {self.vignetting} needs the mirror camera, got camera={self.camera!r}"
            )
        check_choice("camera", self.camera, Camera)
        check_choice("normalise", self.normalise, Normalisation)
        if not isinstance(self.train_also, tuple | list) or not all(
            is_number(h) and math.isfinite(h) and h != 0 for h in self.train_also
        ):
            raise ValueError(
                f"train_also must be a tuple of non-zero hours, got {self.train_also!r}"
            )
        if self.train_also and not self.dynamics:
            raise ValueError("train_also drives at other times of day: it needs dynamics=True")
        check_choice("train_also_order", self.train_also_order, TrainAlsoOrder)
        if self.train_also_order != "frames" and not self.train_also:
            raise ValueError(
                f"train_also_order={self.train_also_order!r} orders the train_also runs: "
                "give train_also (hours) too"
            )
        if self.panorama is not None:
            if not isinstance(self.panorama, tuple | list) or len(self.panorama) != 2:
                raise ValueError(
                    f"panorama must be None or (height, width) in pixels, got {self.panorama!r}"
                )
            for value in self.panorama:
                check_positive_int("panorama", value)
        check_step(600 if self.panorama is None else self.panorama[1], self.step)

    def _validate_clock(self) -> None:
        """The date, the day and the offsets of the ``later`` and ``other_day`` conditions."""
        if self.day_of_year is not None:
            check_day_of_year(self.day_of_year)
        if self.latitude_deg is not None:
            check_latitude(self.latitude_deg)
            if self.day_of_year is None:
                raise ValueError(
                    f"latitude_deg={self.latitude_deg!r} places the sun by date: give a "
                    "day_of_year (1..366) too"
                )
        if self.day is not None:
            check_int_in("day", self.day, 0)
        if self.seasons and self.day_of_year is None:
            raise ValueError("seasons=True sets the foliage by the date: give a day_of_year too")
        if self.grass_seasons and self.day_of_year is None:
            raise ValueError(
                "grass_seasons=True sets the lawn's colour by the date: give a day_of_year too"
            )
        given = [n for n in ("day_of_year", "day") if getattr(self, n) is not None]
        if given and not self.dynamics:
            raise ValueError(f"{given} set the world's dynamics: they need dynamics=True")
        if "other_season" in self.conditions and self.day_of_year is None:
            raise ValueError(
                "the other_season condition tests on a date season_days after the drive's: "
                "date the drive with a day_of_year (1..366)"
            )
        for name, offsets, condition in (
            ("later_hours", self.later_hours, "later"),
            ("other_days", self.other_days, "other_day"),
            ("season_days", self.season_days, "other_season"),
        ):
            several = isinstance(offsets, tuple | list)
            for value in offsets if several else (offsets,):
                if name == "later_hours" and (not is_number(value) or not math.isfinite(value)):
                    raise ValueError(
                        f"later_hours must be a finite number of hours or a tuple of them, got "
                        f"{value!r}"
                    )
                if name == "other_days" and (
                    isinstance(value, bool) or not isinstance(value, int) or value < 1
                ):
                    raise ValueError(
                        f"other_days must be a whole number of days >= 1 or a tuple of them, "
                        f"got {value!r}"
                    )
                if name == "season_days" and (
                    isinstance(value, bool) or not isinstance(value, int) or not 1 <= value < 365
                ):
                    raise ValueError(
                        f"season_days must be a whole number of days in 1..364 or a tuple of "
                        f"them, got {value!r}"
                    )
            if not several:
                continue
            if not offsets:
                raise ValueError(f"{name} must be a number or a non-empty tuple, got ()")
            names = _named(condition, offsets, _SUFFIX[condition])
            if len(set(offsets)) != len(offsets) or len(names) != len(offsets):
                raise ValueError(f"{name} {list(offsets)} repeats an offset (or its name)")
            if condition not in self.conditions:
                raise ValueError(
                    f"{name}={tuple(offsets)!r} gives the offsets of the {condition!r} "
                    f"condition: add {condition} to conditions"
                )

    def offsets(self) -> dict[str, tuple[Condition, float]]:
        """Each test condition, by name, with its kind and its offset (hours after the
        ``after`` run for ``later``, days after the drive's for ``other_day``, days later in
        the year for ``other_season``, else 0), in the order of ``conditions``. A single offset
        keeps the kind's own name (``later``, ``other_day``, ``other_season``); a tuple of them
        gives ``later+2h``, ``other_day+2``, ``other_season+92d``, ..."""
        out: dict[str, tuple[Condition, float]] = {}
        for condition in self.conditions:
            if condition == "later":
                out.update(_named("later", self.later_hours, _SUFFIX["later"]))
            elif condition == "other_day":
                out.update(_named("other_day", self.other_days, _SUFFIX["other_day"]))
            elif condition == "other_season":
                out.update(_named("other_season", self.season_days, _SUFFIX["other_season"]))
            else:
                out[condition] = (condition, 0)
        return out

    @property
    def test_conditions(self) -> tuple[str, ...]:
        """The names of the test conditions scored (see :meth:`offsets`)."""
        return tuple(self.offsets())

    def world_dynamics(self) -> Any:
        """The dynamics of the drive: the world's, with the date and day when given."""
        from sfa_gym.sim.worlds import load_world_spec

        declared = load_world_spec("paper_outdoor").dynamics
        change = {
            name: getattr(self, name)
            for name in ("day_of_year", "latitude_deg", "day", "cloud_cover")
            if getattr(self, name) is not None
        }
        switches = ("seasons", "grass_seasons", "shadows")
        change.update({name: True for name in switches if getattr(self, name)})
        return dataclasses.replace(declared, **change) if change else declared

    def driver(self, part: Literal["train", "test", "both"]) -> Any:
        """The driver of the whole drive (``"both"``) or of one of its paths."""
        from sfa_gym.recording.outdoor_path import OutdoorPathDriver

        return OutdoorPathDriver(
            part,
            train_frames=self.train_frames,
            test_frames=self.test_frames,
            spacing=self.spacing,
            test_spacing=self.test_spacing,
        )

    def env_kwargs(self, condition: str, world_seed: int) -> dict[str, Any]:
        """Keyword arguments of ``gym.make(ENV_ID)`` for the drive (``"after"``: the whole
        drive, starting at ``start_hour``) or for the test run under ``condition`` (a name of
        :attr:`test_conditions`)."""
        kwargs: dict[str, Any] = {
            "world_seed": world_seed,
            "control_dt": self.frame_dt,
            "camera": self.camera,
            "sensor": self.sensor,
            "rover": "outdoor" if self.vibration else "default",
        }
        if self.camera == "cylindrical":
            kwargs["mirror"] = None
        if self.textures:  # only when on: the flat world's runs keep their cache keys
            kwargs["textures"] = True
        if self._sensor_effects:  # likewise
            kwargs["sensor"] = self._sensor_spec()
        if self.panorama is not None:
            from sfa_gym.sim.camera import PanoramaSpec

            height, width = self.panorama
            kwargs["panorama"] = PanoramaSpec(width=int(width), height=int(height))
        if not self.dynamics:
            return {**kwargs, "dynamics": False}
        spec = self.world_dynamics()
        if condition == "after":
            return {**kwargs, "dynamics": dataclasses.replace(spec, start_hour=self.start_hour)}
        kind, offset = self._condition(condition)
        # the test runs start when the "after" part does: the training run's frames later
        hour = (self.start_hour + (self.train_frames * self.frame_dt) / 3600.0) % 24.0
        change = {
            "later": {"start_hour": (hour + offset) % 24.0},
            "no_movers": {"movers": False},
            "overcast": {"overcast": 1.0},
            "other_day": {"day": spec.day + int(offset)},
            "fog": {"overcast": 1.0, "visibility_m": self.fog_visibility_m},
            "rearranged": {"arrangement": spec.arrangement + 1},
            "wet": {"ground": "wet"},
            "snow": {"ground": "snow"},
        }
        if kind == "other_season":  # a dated drive (checked): its date that many days on
            change[kind] = {"day_of_year": (spec.day_of_year - 1 + int(offset)) % 365 + 1}
        spec = dataclasses.replace(spec, **{"start_hour": hour, **change[kind]})
        return {**kwargs, "dynamics": spec}

    @property
    def _sensor_effects(self) -> bool:
        """Whether an effect beyond the default sensor's is on (white balance, vignetting,
        motion blur): the runs then pass a SensorSpec of their own."""
        return bool(self.white_balance or self.vignetting or self.exposure_s)

    def _sensor_spec(self) -> Any:
        """The sensor of the runs with white balance, vignetting or motion blur on (its fields
        checked)."""
        from sfa_gym.sim.camera.sensor import SensorSpec

        return SensorSpec(
            white_balance=self.white_balance,
            vignetting=self.vignetting,
            exposure_s=self.exposure_s,
        )

    def _condition(self, name: str) -> tuple[Condition, float]:
        """The kind and offset of the condition ``name``: one of :meth:`offsets`, or any kind
        whose offset is a single value (its run, scored or not)."""
        offsets = self.offsets()
        if name in offsets:
            return offsets[name]
        single = {
            "later": self.later_hours,
            "other_day": self.other_days,
            "other_season": self.season_days,
        }.get(name, 0)
        if name in CONDITIONS and not isinstance(single, tuple | list):
            return name, single  # type: ignore[return-value]
        raise ValueError(
            f"unknown test condition {name!r}; this config's are {['after', *offsets]}"
        )


_SUFFIX = {"later": "{:+g}h", "other_day": "{:+d}", "other_season": "{:+d}d"}
"""How a condition of several offsets names each: ``later+2h``, ``other_day+2``."""


def _named(
    kind: Condition, offsets: float | Sequence[float], suffix: str
) -> dict[str, tuple[Condition, float]]:
    """``{kind: (kind, offset)}`` for a single offset, else one ``kind + suffix`` per offset."""
    if not isinstance(offsets, tuple | list):
        return {kind: (kind, offsets)}
    return {f"{kind}{suffix.format(o)}": (kind, o) for o in offsets}
