// Camera paths (manifests/paths/*.ron) in the browser: the waypoint walk of
// format/src/path.rs `CameraPath::frames` — at each waypoint turn in place towards
// the next segment at max_turn_deg_per_s, then walk it at max_speed looking along
// it — sampled at any time instead of at frame_rate (paper 000 §4.1's walkthroughs).
// Only the fields the walk needs are read (a small RON subset: numbers, tuples).

export interface CameraPath {
  eyeHeight: number;
  fovYDeg: number;
  maxSpeed: number;
  maxTurnDegPerS: number;
  waypoints: [number, number][];
}

function field(text: string, name: string): string | null {
  const m = new RegExp(`\\b${name}\\s*:\\s*([^,\\n]+)`).exec(text);
  return m ? m[1].trim() : null;
}

export function parsePath(text: string): CameraPath {
  const clean = text.replace(/\/\/[^\n]*/g, "");
  const num = (name: string, def?: number) => {
    const v = field(clean, name);
    const n = v === null ? def : Number(v.replace(/[()]/g, ""));
    if (n === undefined || !Number.isFinite(n) || n <= 0) throw new Error(`camera path: ${name} missing or not a positive number`);
    return n;
  };
  const wp = /waypoints\s*:\s*\[([^\]]*)\]/.exec(clean);
  if (!wp) throw new Error("camera path: no waypoints (views paths are not supported by the web viewer)");
  const waypoints: [number, number][] = [];
  for (const m of wp[1].matchAll(/\(\s*([-0-9.eE+]+)\s*,\s*([-0-9.eE+]+)\s*\)/g)) waypoints.push([Number(m[1]), Number(m[2])]);
  if (waypoints.length < 2 || waypoints.some((p) => !p.every(Number.isFinite))) throw new Error("camera path: at least two finite waypoints needed");
  return {
    eyeHeight: num("eye_height"),
    fovYDeg: num("fov_y_deg", 60),
    maxSpeed: num("max_speed"),
    maxTurnDegPerS: num("max_turn_deg_per_s"),
    waypoints,
  };
}

/** The pose `t` seconds into the walk; `done` once past its end. */
export function walkPose(p: CameraPath, t: number): { eye: [number, number, number]; yaw: number; done: boolean } {
  const rate = (p.maxTurnDegPerS * Math.PI) / 180;
  let heading: number | null = null;
  let rest = t;
  let last = { eye: [0, 0, 0] as [number, number, number], yaw: 0 };
  for (let i = 0; i + 1 < p.waypoints.length; i++) {
    const [a, b] = [p.waypoints[i], p.waypoints[i + 1]];
    const d = [b[0] - a[0], b[1] - a[1]];
    const target = Math.atan2(d[1], d[0]);
    if (heading !== null) {
      let delta = target - heading;
      while (delta > Math.PI) delta -= 2 * Math.PI;
      while (delta < -Math.PI) delta += 2 * Math.PI;
      const dur = Math.abs(delta) / rate;
      if (rest <= dur) return { eye: [a[0], p.eyeHeight, a[1]], yaw: heading + (delta * rest) / dur, done: false };
      rest -= dur;
    }
    const dur = Math.hypot(d[0], d[1]) / p.maxSpeed;
    if (rest <= dur) {
      const f = rest / dur;
      return { eye: [a[0] + d[0] * f, p.eyeHeight, a[1] + d[1] * f], yaw: target, done: false };
    }
    rest -= dur;
    heading = target;
    last = { eye: [b[0], p.eyeHeight, b[1]], yaw: target };
  }
  return { ...last, done: true };
}
