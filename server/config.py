"""Server settings: one validated object, built once at startup and passed explicitly."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from devices.capability import CapabilityReport, check
from devices.manager import DeviceConfig, DeviceConfigError, check_unique, rig_points, with_fingers
from devices.browser import check_configs as check_browser_configs
from devices.profiles import profile_by_model
from scenarios import registry
from scenarios.free import ID as FREE_SCENARIO
from server.core.haptics import contact_gate as gate_defaults
from server.cpu_plan import check_mode
from server.loop.cadence import STATE_HZ
from server.loop.process import LoopConfig
from server.loop.tracker_udp import is_loopback
from server.core.points import PRIMARY_POINT, check_point_name
from server.core.scenario import required_dimensions
from server.core.scene import Scene
from server.tracking.sources import SourceSpec, parse_specs

WEB_ROOT = Path(__file__).resolve().parents[1] / "clients" / "web"
STUDIES_DIR = Path(__file__).resolve().parents[1] / "studies"


@dataclass(frozen=True)
class Settings:
    host: str = "127.0.0.1"
    port: int = 8000
    scenario: str | None = None    # None: free-v1 when there is a scene_file, else registry.DEFAULT_SCENARIO
    scenario_params: dict = field(default_factory=dict)  # the scenario's PARAMS (docs/scenarios.md)
    scene_file: str | None = None
    tick_hz: int = 1000
    state_hz: float = STATE_HZ
    realtime: bool = True
    loop_cpu: str = "auto"         # the loop's CPU: "auto", "shared" or "own" (server/cpu_plan.py)
    gate_band: float = gate_defaults.BAND         # contact hysteresis band, scene units (docs/haptics.md)
    gate_dwell_s: float = gate_defaults.MIN_DWELL_S  # minimum on and off time of the debounced contact
    web_root: Path = field(default=WEB_ROOT)
    max_frame_bytes: int = 1 << 20  # frames above this close the connection (1009); 64 KiB+ get an error
    devices: tuple[DeviceConfig, ...] = ()  # real devices (docs/devices.md)
    simulated_rig: bool = True      # device emulators on ptys, when no device is configured
    rig_models: tuple[str, ...] = ("fingertac", "ferrovibe")
    data_dir: Path = Path("data")   # the experiment database (viestac.sqlite) lives here
    studies_dir: Path = STUDIES_DIR  # study files (*.toml) the console offers
    record_every: int = 10          # trajectory rows every Nth tick during a trial (1: every tick)
    force: bool = False             # run scenarios no configured device can show (serve --force; studies too)
    tracker_udp: str = "auto"       # the loop's tracker UDP port: "auto" (HTTP host, HTTP port + 1), HOST:PORT, PORT, "off"
    overrun_threshold: int = 10     # health is degraded above this many loop overruns (> 1.5 ms) per 10 s
    lease_ttl_s: float = 60.0       # the control lease goes when its holder has been quiet this long (server/auth/lease.py)
    tls_cert: Path | None = None    # HTTPS/WSS: PEM certificate and key (viestac tls init makes both)
    tls_key: Path | None = None
    allowed_hosts: tuple[str, ...] = ()    # Host names answered besides the defaults (docs/security.md); "*": any
    allowed_origins: tuple[str, ...] = ()  # page origins allowed besides the server's own (also CORS)
    login_link: bool = True         # print a single-use admin login link at start
    trackers: tuple[str, ...] = ()  # tracker sources run by the tracker host (serve --tracker; docs/trackers.md)
    fingers: tuple[tuple[str, str], ...] = ()  # (device name, point): serve --finger NAME=POINT (docs/devices.md)

    def __post_init__(self) -> None:
        if not 0 <= self.port <= 65535:
            raise ValueError("port must be in 0..65535")
        if not 100 <= self.tick_hz <= 10_000:
            raise ValueError("tick_hz must be in 100..10000")
        if not 1 <= self.state_hz <= min(self.tick_hz, 1000):
            raise ValueError("state_hz must be in 1..tick_hz")
        check_mode(self.loop_cpu)
        if not 1 <= self.record_every <= 1000:
            raise ValueError("record_every must be in 1..1000 ticks")
        if not 0 <= self.overrun_threshold <= 10_000:
            raise ValueError("overrun_threshold must be in 0..10000 overruns per 10 s")
        if not 1.0 <= self.lease_ttl_s <= 30 * 86400:
            raise ValueError("lease_ttl_s must be in 1..2592000 s (30 days)")
        if not (0.0 <= self.gate_band <= 0.1 and 0.0 <= self.gate_dwell_s <= 1.0):
            raise ValueError("gate band must be in [0, 0.1] scene units and dwell in [0, 1] s")
        if self.scenario is None:  # serve --scene FILE.json alone: explore the file
            object.__setattr__(self, "scenario", FREE_SCENARIO if self.scene_file is not None
                               else registry.DEFAULT_SCENARIO)
        spec = registry.resolve(self.scenario)  # fails early, with a hint
        object.__setattr__(self, "scenario", spec.id)
        object.__setattr__(self, "scenario_params", registry.check_scenario_params(spec, self.scenario_params))
        for model in self.rig_models:
            profile_by_model(model)
        check_unique(list(self.devices))
        check_browser_configs(list(self.devices))
        self.device_fingers()  # fails early: a --finger for no device, or not a point name
        if self.scene_file is not None:
            Scene.load(self.scene_file)  # fails early with the offending field
        self.tracker_address()  # fails early with what is wrong
        if self.trackers and self.tracker_address() is None:
            raise ValueError("--tracker needs the tracker UDP port (--tracker-udp is off)")
        self.tracker_specs()  # fails early: an unknown kind, a missing replay file, a bad CSV line
        if (self.tls_cert is None) != (self.tls_key is None):
            raise ValueError("--tls-cert and --tls-key go together")
        for path in (self.tls_cert, self.tls_key):
            if path is not None and not Path(path).is_file():
                raise ValueError(f"TLS file {path} does not exist (viestac tls init makes one)")

    @property
    def scheme(self) -> str:
        return "https" if self.tls_cert is not None else "http"

    def tracker_address(self) -> tuple[str, int] | None:
        """Where the tracker UDP port binds; None when it is off. Loopback only: the port has no
        authentication, so only the rig PC's own processes (its tracker bridges) may send to it
        (docs/security.md). "auto" is 127.0.0.1 at the HTTP port + 1 (a free port when the HTTP
        port is 0); another address is refused with ValueError."""
        text = self.tracker_udp.strip()
        if text == "off":
            return None
        if text == "auto":
            return "127.0.0.1", (self.port + 1 if 0 < self.port < 65535 else 0)
        host, colon, port = text.rpartition(":")
        try:
            number = int(port)
        except ValueError:
            number = -1
        if not 0 <= number <= 65535 or (colon and not host):
            raise ValueError(f"tracker UDP port {self.tracker_udp!r}: expected HOST:PORT, PORT (0..65535), "
                             "'auto' or 'off'")
        host = (host or "127.0.0.1").strip("[]")
        if not is_loopback(host):
            raise ValueError(f"tracker UDP port {self.tracker_udp!r}: the tracker port binds to loopback only "
                             "(127.0.0.1 or ::1), because it has no authentication; run the tracker bridge on the "
                             "rig PC, or send its samples over /ws with a token (docs/security.md)")
        return host, number

    def tracker_specs(self) -> tuple[SourceSpec, ...]:
        return parse_specs(self.trackers)

    def device_configs(self, rig: list[DeviceConfig] = ()) -> list[DeviceConfig]:
        """The devices to drive (the configured ones, or the simulated rig's `rig`), each on its
        finger: the rig file's `finger`, overridden by --finger."""
        configs = with_fingers(list(self.devices) or list(rig), dict(self.fingers))
        check_browser_configs(configs)  # one browser device at most, on the primary point
        return configs

    def device_fingers(self) -> dict[str, str]:
        """Device name → the tracked point it sits on (known before the simulated rig starts);
        DeviceConfigError for a --finger naming no device or no point."""
        base = ({d.name: d.finger for d in self.devices} if self.devices
                else {m: PRIMARY_POINT for m in (self.rig_models if self.simulated_rig else ())})
        unknown = sorted(set(dict(self.fingers)) - set(base))
        if unknown:
            raise DeviceConfigError(f"--finger names no device: {', '.join(unknown)}; devices: "
                                    f"{', '.join(base) or 'none'}")
        for name, point in self.fingers:
            try:
                check_point_name(point)
            except ValueError as exc:
                raise DeviceConfigError(f"--finger {name}={point}: {exc}") from None
        return {**base, **dict(self.fingers)}

    def loop_config(self, cpu: int | None = None) -> LoopConfig:
        """`cpu`: the loop's CPU from the server's CpuPlan (None: not pinned)."""
        return LoopConfig(scenario=self.scenario, scenario_params=self.scenario_params, scene_file=self.scene_file,
                          scene_for=self.scenario if self.scene_file is not None else None,
                          tick_hz=self.tick_hz, cpu=cpu,
                          state_hz=self.state_hz, realtime=self.realtime, gate_band=self.gate_band,
                          gate_min_on_s=self.gate_dwell_s, gate_min_off_s=self.gate_dwell_s,
                          rig=rig_points(self.device_fingers().values()))

    def recorded(self) -> dict:
        """The configuration as plain data, stored with every experiment session."""
        out = {}
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if name == "devices":
                value = [{"name": d.name, "model": d.profile.model, "port": d.where, "finger": d.finger}
                         for d in value]
            elif isinstance(value, Path):
                value = str(value)
            elif isinstance(value, tuple):
                value = list(value)
            out[name] = value
        return out

    def device_profiles(self) -> dict:
        """The profiles the server will drive: the configured devices, else the simulated rig's."""
        if self.devices:
            return {d.name: d.profile for d in self.devices}
        if self.simulated_rig:
            return {model: profile_by_model(model) for model in self.rig_models}
        return {}

    def capability(self) -> CapabilityReport:
        cls = registry.resolve(self.scenario).factory
        return check(cls.id, required_dimensions(cls, self.scenario_params), self.device_profiles())
