"""Live fit: while `scene.quatcurve_fit.live` is on, fitted targets stay fitted as the animator edits
their rotation keys (insert, delete, move in time, change a value, undo, redo): the target is refitted
with the settings of its fit record — the generated keys and the handles are written again, the
animator's own keys are never moved, deleted or changed (fit.py).

How it decides, cheapest test first:

1. `depsgraph_update_post` (persistent: kept across file loads) returns at once when the scene's
   toggle is off or when no Action with fit records is among `depsgraph.updates` (an Action is listed
   when its keys change). The names of the changed fitted actions are noted (names, never
   references: undo and file loads replace the data behind them).
2. A noted action is checked target by target: the signature of the animator's keys
   (`fit.read_animator_keys(target).signature()`) against the record's. Equal (a location key, a
   selection, our own write coming back as an update): nothing happens. Different: refit.
3. When: in background mode at once, inside the handler (keys written there do not trigger it again,
   and a second update from our own write finds equal signatures: no loop). With a window, from a
   `bpy.app.timers` callback, never inside the depsgraph callback, and never during a drag: Blender
   4.2+ lists the running modal operators of each window (`Window.modal_operators`); while one that
   edits keys runs (a transform, a graph slider) the timer polls until it is gone — refitting then
   would free the key array the transform writes into. Blender 3.4 has no such list: there the
   timer waits until the keys have not changed for `DEBOUNCE` seconds (each update restarts the
   wait). `drag_hook` lets tests (and scripts) say that a drag runs.
4. Undo: the refit is written outside any undo step (no `ed.undo_push`: a step of its own would make
   one user edit two undo steps). The step the edit pushed holds the keys before the refit, so undo
   lands exactly on the state before the edit; redo lands on the edit without its refit, and
   `undo_post`/`redo_post` check every fitted action again, which refits it (deterministically, to
   the same keys). F-curves are looked up again every time, never kept.

`STATS` counts handler calls, signature checks and refits and times the stages (tests and
tests/bench/bench_live.py read it).
"""

import hashlib
import itertools
import time
from dataclasses import dataclass, field

import bpy
import numpy as np

from . import cycles, fcurves, fit, native
from .workers import thread_count

DEBOUNCE = 0.3   # seconds without a key change before Blender 3.4 refits (it cannot see a drag)
POLL = 0.1       # seconds between checks while a drag runs (4.2+)
HAS_MODAL_LIST = "modal_operators" in bpy.types.Window.bl_rna.properties  # 4.2+
# Modal operators that edit keys while they run: no refit until they are gone.
DRAG_PREFIXES = ("TRANSFORM_OT_", "GRAPH_OT_", "ACTION_OT_", "ANIM_OT_", "POSE_OT_", "NLA_OT_", "SEQUENCER_OT_")

# Tests and scripts: a callable returning True while a drag should be assumed to run (None: ask Blender).
drag_hook = None


@dataclass
class Stats:
    """What live mode did since the last reset(): handler calls, targets checked, targets refitted,
    deferrals (drag or debounce), errors (one line each), and seconds per stage."""
    calls: int = 0
    checks: int = 0
    refits: int = 0
    deferred: int = 0
    errors: list = field(default_factory=list)
    seconds: dict = field(default_factory=dict)

    def reset(self):
        self.__init__()

    def add(self, stage, seconds):
        self.seconds[stage] = self.seconds.get(stage, 0.0) + seconds


STATS = Stats()

_pending = {}          # action name → name of the scene whose toggle asked for it
# (action name, slot, owner path) → raw_digest of a target whose full check found its keys fitted:
# while the digest stays the same its keys are not read again. Dropped by a refit of the target,
# undo, redo and file loads.
_unchanged = {}
_check_all = set()     # scene names: check every fitted action (undo, redo, live switched on)
_last_change = 0.0     # perf_counter() of the last relevant update (3.4's debounce)
_timer_on = False
_busy = False


def live_enabled(scene):
    settings = getattr(scene, "quatcurve_fit", None) if scene is not None else None
    return bool(settings is not None and settings.live)


def _windowed():
    """Blender runs with windows (an event loop runs the timers); background mode has none."""
    return not bpy.app.background


def _windows():
    wm = getattr(bpy.context, "window_manager", None)
    return list(wm.windows) if wm is not None else []


def drag_in_progress():
    """True while a drag may be editing keys: `drag_hook()` when set; else, on 4.2+, a modal operator
    of the DRAG_PREFIXES families running in any window. 3.4 cannot tell (False: the debounce covers it)."""
    if drag_hook is not None:
        return bool(drag_hook())
    if not HAS_MODAL_LIST:
        return False
    for window in _windows():
        for op in getattr(window, "modal_operators", ()):
            if op.bl_idname.startswith(DRAG_PREFIXES):
                return True
    return False


def raw_digest(target):
    """A digest of what the fit reads of `target` as Blender stores it — rotation mode, and per
    rotation channel its keys' frames, values and types, its modifiers (count, and the loop they make) — plus the ID's driver
    count, taken with two bulk reads per channel: equal digests mean nothing the fit reads changed."""
    return _raw_read(target)[0]


def _raw_read(target):
    """(raw_digest, the rotation F-curves it read, their fcurves.read_co_types or None): a changed
    target's full read (fit.read_animator_keys) takes the F-curves and arrays instead of finding and
    reading them again. Channels keyed together (the usual case) are read into shared arrays and
    hashed at once."""
    mode = target.owner.rotation_mode
    prop, count = fcurves.rotation_property(mode)
    anim = target.id_data.animation_data
    h = hashlib.blake2b(("%s %d" % (mode, len(anim.drivers) if anim is not None else 0)).encode(), digest_size=16)
    channels = fcurves.Channels.of(target.id_data)
    curves = channels.find_all(target.data_path(prop), count) if channels is not None else [None] * count
    read = fcurves.read_co_types(curves)
    if read is not None:
        modifiers = [len(curve.modifiers) for curve in curves]
        h.update(b"together %d %r|" % (read[1].shape[1], modifiers))
        for curve, m in zip(curves, modifiers):
            if m:  # a Cycles modifier's settings make the target a loop or refuse it
                h.update(repr(cycles.channel_cycle(curve)).encode())
        h.update(read[0].tobytes())
        h.update(read[1].tobytes())
        return h.digest(), curves, read
    for curve in curves:
        if curve is None:
            h.update(b"-")
            continue
        points = curve.keyframe_points
        n = len(points)
        co = np.empty(2 * n, dtype=np.float32)
        types = np.empty(n, dtype=fcurves.KEY_ENUM_READ_DTYPE)
        points.foreach_get("co", co)
        points.foreach_get("type", types)
        h.update(b"%d %d|" % (n, len(curve.modifiers)))
        if len(curve.modifiers):  # a Cycles modifier's settings make the target a loop or refuse it
            h.update(repr(cycles.channel_cycle(curve)).encode())
        h.update(co.tobytes())
        h.update(types.tobytes())
    return h.digest(), curves, None


def _fitted_action_names(depsgraph):
    """Names of the (original) Actions with fit records among the depsgraph's updates."""
    names = []
    for update in depsgraph.updates:
        data = update.id
        if isinstance(data, bpy.types.Action):
            action = data.original
            if len(getattr(action, "quatcurve_fits", ())) and action.library is None:
                names.append(action.name)
    return names


@bpy.app.handlers.persistent
def on_depsgraph_update(scene, depsgraph=None):
    """Notes the fitted actions whose keys may have changed; refits now (background) or soon (timer)."""
    if _busy or not live_enabled(scene):
        return
    STATS.calls += 1
    names = _fitted_action_names(depsgraph) if depsgraph is not None else []
    if not names and not _check_all:
        return
    for name in names:
        _pending[name] = scene.name
    _soon()


def switched(scene):
    """The scene's toggle changed (its update callback, fit_ops): switched on, every fitted action is
    checked — targets edited while it was off are refitted; switched off, nothing stays pending."""
    if live_enabled(scene):
        _check_all.add(scene.name)
        _soon()
    else:
        _check_all.discard(scene.name)
        for name in [n for n, s in _pending.items() if s == scene.name]:
            del _pending[name]


def _soon():
    """Refit now (background mode: no event loop) or from a timer (with a window)."""
    global _last_change
    _last_change = time.perf_counter()
    if _windowed():
        _schedule(0.0 if HAS_MODAL_LIST else DEBOUNCE)
    else:
        process_pending()


@bpy.app.handlers.persistent
def on_undo_redo(scene, *args):
    """After undo/redo every fitted action of the scene is checked (the step loaded may hold keys
    edited before their refit); the old pending names may point at replaced data."""
    _pending.clear()
    _unchanged.clear()
    if live_enabled(scene):
        _check_all.add(scene.name)
        _soon()


@bpy.app.handlers.persistent
def on_load(*args):
    """A file was loaded: nothing pending refers to it."""
    _pending.clear()
    _unchanged.clear()
    _check_all.clear()
    fit.forget_fits()


def _schedule(delay):
    global _timer_on
    if not _timer_on:
        _timer_on = True
        bpy.app.timers.register(_timer, first_interval=max(delay, 0.01))


def _timer():
    global _timer_on
    try:
        again = process_pending()
    except Exception as error:  # noqa: BLE001 — a timer must not die with work left
        STATS.errors.append("live: %s" % error)
        again = None
    if again is None:
        _timer_on = False
    return again


def process_pending():
    """Refits the noted actions' changed targets, unless a drag runs (→ POLL) or, on 3.4 with a window,
    the keys changed less than DEBOUNCE seconds ago (→ the time left). Returns the seconds until the
    next try (what a bpy.app.timers callback returns), or None when done."""
    if not _pending and not _check_all:
        return None
    if drag_in_progress():
        STATS.deferred += 1
        return POLL
    if not HAS_MODAL_LIST and _windowed():
        wait = DEBOUNCE - (time.perf_counter() - _last_change)
        if wait > 0:
            STATS.deferred += 1
            return wait
    names = dict(_pending)
    _pending.clear()
    for scene_name in list(_check_all):
        for action in bpy.data.actions:
            if len(getattr(action, "quatcurve_fits", ())) and action.library is None:
                names.setdefault(action.name, scene_name)
    _check_all.clear()
    for name, scene_name in names.items():
        action = bpy.data.actions.get(name)
        if action is None or not live_enabled(bpy.data.scenes.get(scene_name)):
            continue
        refit_action(action)
    return None


def refit_action(action):
    """Refits every target of `action` whose animator keys no longer match its fit record, each with
    its record's settings; the others are left untouched. Returns the names refitted. A target that
    cannot be fitted now (a NaN key, one key left, a modifier added) is left as it is and noted in
    STATS.errors."""
    with fit.record_index():
        return _refit_action(action)


def _refit_action(action):
    global _busy
    done = []
    t0 = time.perf_counter()
    found = fit.fitted_targets(action)
    STATS.add("targets", time.perf_counter() - t0)
    # Read and compare on the main thread; each changed target goes to a quatcurve.FitQueue as soon as
    # it is read, whose native worker threads fit it (fit_channels) without ever needing the GIL while
    # the main thread reads the next ones; then, in order, each fit's plan (fit.plan_of) and write on
    # the main thread. A target whose raw digest is the one its last full check found fitted is not
    # read again; two objects playing one action's rotation channels (same slot and mode) are refitted
    # once.
    changed = _changed_targets(action, found)
    first = list(itertools.islice(changed, 2))
    # One refit (an edit of one target): no worker threads to start, the fit runs when it is taken.
    queue = native.require().FitQueue(threads=thread_count() if len(first) == 2 else 0)
    pending = []  # (target, (keys, settings, eases) or the FitError or None), in push order
    # The fits the new ones replace are freed once the workers are done: their memory comes from the
    # workers' malloc arenas, and freeing it while they allocate waits on the arenas' locks (46 µs a
    # fit inside the loop, bpy 5.0.1; 10–13 µs after it).
    replaced = []
    for target, keys, settings, eases, previous in itertools.chain(first, changed):
        replaced.append(previous)
        job = fit.fit_job(keys, settings, *eases)
        if job is None:  # fewer than two keys: nothing to fit, the record waits for more
            pending.append((target, None))
            continue
        options, used = job
        try:
            queue.push(keys.frames, keys.values, keys.mode, settings.method, previous=previous, **options)
        except ValueError as error:
            pending.append((target, fit.fit_error(keys, error)))
            continue
        pending.append((target, (keys, settings, used)))
    queue.close()
    t2 = time.perf_counter()
    for target, job in pending:
        # The wait for this fit, and its plan's Python.
        result = job
        if isinstance(job, tuple):
            keys, settings, used = job
            try:
                kf = next(queue)
            except ValueError as error:
                result = fit.fit_error(keys, error)
            else:
                result = fit.plan_of((keys, settings, kf) + used)
        t3 = time.perf_counter()
        STATS.add("plan", t3 - t2)
        if isinstance(result, fit.FitError):
            STATS.errors.append(str(result))
        elif result is not None:
            _busy = True
            try:
                fit.write_plan(result, target)
            finally:
                _busy = False
            STATS.refits += 1
            done.append(target.name)
        t2 = time.perf_counter()
        STATS.add("write", t2 - t3)
    del queue
    replaced.clear()
    return done


def _changed_targets(action, found):
    """(target, keys, settings, eases, previous) of each target of `action` whose animator keys no
    longer match its fit record; counts the checks and times them (read, signature)."""
    seen = set()
    for target in found:
        t0 = time.perf_counter()
        record = fit.find_record(action, target)
        key = (action.name,) + fit.target_key(target)
        if record is None:
            continue
        channels = key + (target.owner.rotation_mode,)  # the F-curves this target's refit writes
        if channels in seen:
            continue
        seen.add(channels)
        known = _unchanged.pop(key, None)
        raw, curves, read = _raw_read(target)
        if raw == known:
            _unchanged[key] = raw
            STATS.checks += 1
            STATS.add("read", time.perf_counter() - t0)
            continue
        try:
            keys = fit.read_animator_keys(target, curves, read)
        except fit.FitError as error:
            STATS.errors.append(str(error))
            continue
        t1 = time.perf_counter()
        same = keys.signature() == record.signature
        t2 = time.perf_counter()
        STATS.checks += 1
        STATS.add("read", t1 - t0)
        STATS.add("signature", t2 - t1)
        if same:
            _unchanged[key] = raw
        else:
            yield (target, keys, fit.settings_of(record), fit.refit_eases(keys, target, record),
                   fit.last_fit(action, target))


_handlers = (
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.undo_post, on_undo_redo),
    (bpy.app.handlers.redo_post, on_undo_redo),
    (bpy.app.handlers.load_post, on_load),
)


def register():
    for handlers, handler in _handlers:
        if handler not in handlers:
            handlers.append(handler)


def unregister():
    global _timer_on
    for handlers, handler in _handlers:
        while handler in handlers:
            handlers.remove(handler)
    if _timer_on and bpy.app.timers.is_registered(_timer):
        bpy.app.timers.unregister(_timer)
    _timer_on = False
    on_load()
