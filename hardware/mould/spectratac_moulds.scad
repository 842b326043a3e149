// SpectraTac moulds and assembly fixture (OpenSCAD 2021.01), parametric.
// Every dimension comes from params.scad, which `make hardware` writes from hardware/definitions/params.toml
// (the same numbers the PCB generator uses). Pick a part with -D 'part="..."':
//   pdms_mould   open cup that casts the transparent PDMS light guide, upside down: its floor
//                bosses leave pockets for the three sensors and three LEDs
//   skin_cavity  outer half of the black-skin mould: casts the skin cup's outside
//   skin_core    inner half: a plug that hangs from a lid and forms the skin's inside
//   fixture      a bore the finished stack fits: skin cup upside down, PDMS disc in it, board
//                face down on top, flush with the rim so it can be pressed flat while bonding
// Units: mm. z = 0 is the bottom of every printed part.

include <params.scad>

part = "pdms_mould";
$fn = 96;

pdms_r = board_radius - skin_wall;             // PDMS disc radius
pdms_h = stack_height - board_thickness - skin_top;
skin_h = stack_height - board_thickness;       // skin cup height (top + wall)

// Bosses that form the component pockets. The disc is cast upside down, so a pocket in its
// underside is a boss on the mould floor, at the mirrored angle.
module pocket_bosses() {
    for (a = sensor_angles) pocket_boss(a, sensor_body);
    for (a = led_angles) pocket_boss(a, led_body);
}
module pocket_boss(angle, body) {
    rotate([0, 0, -angle]) translate([ring_radius, 0, 0])
        translate([-(body[0] / 2 + pocket_clearance), -(body[1] / 2 + pocket_clearance), 0])
            cube([body[0] + 2 * pocket_clearance, body[1] + 2 * pocket_clearance,
                  body[2] + pocket_extra_depth]);
}

module pdms_mould() {
    outer_r = pdms_r + mould_wall;
    difference() {
        cylinder(r = outer_r, h = mould_floor + pdms_h);
        translate([0, 0, mould_floor]) cylinder(r = pdms_r, h = pdms_h + 1);
    }
    translate([0, 0, mould_floor]) pocket_bosses();
}

module skin_cavity() {
    outer_r = board_radius + mould_wall;
    difference() {
        cylinder(r = outer_r, h = mould_floor + skin_h);
        translate([0, 0, mould_floor]) cylinder(r = board_radius, h = skin_h + 1);
    }
}

// The core sits on the cavity's rim: its lid rests on top, its plug reaches down to leave
// skin_top of Ecoflex between plug and cavity floor. Printed lid-down (plug pointing up).
module skin_core() {
    lid_r = board_radius + mould_wall;
    plug_h = skin_h - skin_top;
    cylinder(r = lid_r, h = mould_floor);
    translate([0, 0, mould_floor]) cylinder(r = pdms_r, h = plug_h);
}

// Fixture: a bore as deep as the whole stack, so the board's back ends flush with the rim, and
// a hole in the floor to push the bonded sensor out with a blunt rod.
module fixture() {
    bore_r = board_radius + fixture_clearance;
    depth = stack_height;
    outer_r = bore_r + mould_wall;
    difference() {
        cylinder(r = outer_r, h = mould_floor + depth);
        translate([0, 0, mould_floor]) cylinder(r = bore_r, h = depth + 1);
        translate([0, 0, -1]) cylinder(r = eject_hole_radius, h = mould_floor + 2);
    }
}

if (part == "pdms_mould") pdms_mould();
else if (part == "skin_cavity") skin_cavity();
else if (part == "skin_core") skin_core();
else if (part == "fixture") fixture();
else assert(false, str("unknown part ", part));
