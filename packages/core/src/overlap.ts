/**
 * Robots sharing one world that can touch each other, said in words: the scene's other robots at
 * generate, the twins of one `robwot serve`. A robot's reach is its end link's reach box in the world
 * frame (workspace.json `reachBounds`); a robot whose reach is unknown (a scene's other robot at
 * generate, any robot before its workspace is sampled) is judged by its base alone. Also: a start pose
 * that already touches something (`startCollision`).
 */
import type { Bounds, Contact, Vec3 } from "./backend-contract.js";
import { norm, sub } from "./geometry.js";

export interface PlacedRobot {
  name: string;
  /** base position in the world frame (m) */
  base: Vec3;
  reach?: Bounds;
}

/** Bases closer than this (m) stand at the same place: the robots interpenetrate. */
export const SAME_BASE = 0.05;

const inside = (p: Vec3, b: Bounds): boolean => p.every((v, i) => v >= b.min[i]! && v <= b.max[i]!);
const meet = (a: Bounds, b: Bounds): boolean => a.min.every((_, i) => a.min[i]! <= b.max[i]! && b.min[i]! <= a.max[i]!);
const at = (p: Vec3): string => `[${p.map((v) => v.toFixed(3)).join(", ")}] m`;

/** One sentence per pair of robots that can touch (nothing for robots out of each other's reach). */
export function reachOverlaps(robots: readonly PlacedRobot[]): string[] {
  const out: string[] = [];
  robots.forEach((a, i) => {
    for (const b of robots.slice(i + 1)) {
      const d = norm(sub(a.base, b.base));
      if (d < SAME_BASE) {
        out.push(`${a.name} and ${b.name} stand at the same place (bases ${at(a.base)} and ${at(b.base)}): they overlap, so nearly every configuration of one collides with the other; place them apart (--base, or the scene's robots entries)`);
      } else if ((a.reach && inside(b.base, a.reach)) || (b.reach && inside(a.base, b.reach))) {
        const [reacher, other] = a.reach && inside(b.base, a.reach) ? [a, b] : [b, a];
        out.push(`${other.name} stands within ${reacher.name}'s reach (${d.toFixed(3)} m apart): each is an obstacle to the other's moves and validations`);
      } else if (a.reach && b.reach && meet(a.reach, b.reach)) {
        out.push(`${a.name} and ${b.name} can reach into the same space (their reach boxes overlap): each is an obstacle to the other's moves and validations`);
      }
    }
  });
  return out;
}

const side = (s: Contact["a"]): string => (s.link === null ? s.body : `${s.body}/${s.link}`);

/** Pairs named by `startCollision`; the others are counted. */
const NAMED_PAIRS = 4;

/**
 * A start pose in contact, in words (`robot.checkCollision`'s contacts at it), or undefined when it is free:
 * the pairs touching, deepest first (the rest counted), and what that means for the twin's moves.
 */
export function startCollision(who: string, contacts: readonly Contact[]): string | undefined {
  if (contacts.length === 0) return undefined;
  const pairs = [...contacts].sort((x, y) => y.depth - x.depth).map((c) => `${side(c.a)} with ${side(c.b)} (${(c.depth * 1000).toFixed(1)} mm deep)`);
  const more = pairs.length > NAMED_PAIRS ? ` and ${pairs.length - NAMED_PAIRS} more pair(s)` : "";
  return `${who} collides (${pairs.slice(0, NAMED_PAIRS).join(", ")}${more}): a move must first leave the contact (only a path along which it recedes until free is allowed); choose another start pose (generate --home J=V,...) or move what it touches`;
}
