"""Mouse clicks the window sessions share (simulated events; Blender started with
--enable-event-simulate): choosing the sidebar's tab, opening closed subpanels.

Each function is a generator: the session's timer steps it, so Blender redraws between clicks and the
panels' draw functions (recorded in `drawn`, panel idname -> count) show what opened."""


def click(win, x, y):
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=int(x), y=int(y))
    win.event_simulate(type="LEFTMOUSE", value="PRESS", x=int(x), y=int(y))
    win.event_simulate(type="LEFTMOUSE", value="RELEASE", x=int(x), y=int(y))


def park_mouse(win, area):
    """The mouse in the area's corner, where it shows no tooltip."""
    win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=area.x + 5, y=area.y + 5)


def open_subpanels(win, area, drawn, panels, header=24):
    """Clicks up the sidebar from its bottom, left of the subpanel headers' arrows (and of a header's
    checkbox), until every panel in `panels` has drawn (a closed subpanel draws only its header). A
    subpanel asked for that opens is not clicked again: the scan moves up by a header's height
    (`header` pixels at UI scale 1). One not asked for that opens on the way is closed again (its
    header stays where it was: opening grows downward). Nothing above the highest panel asked for is
    clicked, so no button of an open panel is pressed. Clicks below the panels go through to the
    editor (in the 3D Viewport they deselect): the session selects again afterwards."""
    import bpy
    region = next(r for r in area.regions if r.type == "UI")
    x = region.x + int(28 * bpy.context.preferences.view.ui_scale)
    wanted = set(panels)
    y = region.y + 6
    while y < region.y + region.height and not all(drawn.get(p) for p in wanted):
        before = set(drawn)
        click(win, x, y)
        yield
        yield
        opened = [p for p in drawn if p not in before]
        for other in [p for p in opened if p not in wanted]:
            click(win, x, y)
            drawn.pop(other, None)
            yield
            yield
        y += header * bpy.context.preferences.view.ui_scale if any(p in wanted for p in opened) else 6
    park_mouse(win, area)
    yield
