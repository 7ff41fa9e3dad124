// The page plays football: against a real `inertia-football` dev server,
// it reads the game's name from the welcome, decodes football's messages,
// shows the score line from the match's properties, sends football's own
// input (refused nowhere) and its asks (a chat line, a team switch).
//
// Run by `npm run test:browser` after the football server is built
// (INERTIA_FOOTBALL_BIN names another build).

import assert from "node:assert/strict";
import { join } from "node:path";
import { after, before, test } from "node:test";

import { close, open, ROOT, until, type Session } from "./harness.js";

const FOOTBALL = process.env.INERTIA_FOOTBALL_BIN ?? join(ROOT, "target/debug/inertia-football");

let s: Session;

before(async () => {
  s = await open(FOOTBALL);
});

after(async () => {
  await close(s);
});

test("the page plays football: its messages, its score line, its input and its asks", async () => {
  const p = await until(s.page, "joined", 30_000, (p) => p.snapshots >= 30 && p.headline !== null);
  assert.equal(p.game, "football");
  // Alone on the pitch: red, waiting for a player on blue.
  await until(s.page, "the join told", 10_000, (p) => p.log.some((l) => l.endsWith("plays for red")));
  await until(s.page, "the score line", 10_000, (p) =>
    p.headline === "red 0 – 0 blue · 0:00 · waiting for a player on each team",
  );
  // Run and kick for a second: football's six bytes, refused nowhere.
  await s.page.keyboard.down("w");
  await s.page.keyboard.down("e");
  await new Promise((r) => setTimeout(r, 1000));
  await s.page.keyboard.up("e");
  await s.page.keyboard.up("w");
  const metrics = await (await fetch(`http://${s.http}/metrics`)).text();
  assert.match(metrics, /^inertia_inputs_rejected_total 0$/m, "the page's inputs were taken");
  // T asks to switch team; Enter says something.
  await s.page.keyboard.press("t");
  await until(s.page, "the switch told", 10_000, (p) => p.log.some((l) => l.endsWith("plays for blue")));
  s.page.once("dialog", (d) => void d.accept("goal!"));
  await s.page.keyboard.press("Enter");
  await until(s.page, "the chat line back", 10_000, (p) => p.log.some((l) => l.endsWith(": goal!")));
});
