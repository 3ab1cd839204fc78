#!/bin/sh
# SPDX-License-Identifier: MIT
# The gateway's robot boundary (docs/gateway.md, issue 13): the robot
# (gateway/robot.[ch]) and its link (gateway/link.[ch]) know nothing of
# Modbus, and the other northbound sides (GPIO, MQTT) read the robot
# (gw_robot_t), not Modbus's units; nor does the console's HTTP side,
# which hears of Modbus only through the sides' reports. Fails if one of
# those files includes a Modbus header or names a Modbus-side symbol outside its comments
# (stripped by the preprocessor first, so a comment may say why).
# usage: gw-boundary.sh RESULTS [TOP]   (TOP: the tree to check, default .)
results=$1; top=${2:-.}
label="gateway robot boundary (no Modbus in robot, link, GPIO, MQTT)"
mkdir -p "$(dirname "$results")"
# GNU cpp strips the comments and keeps the rest as written (not clang)
cc=${GW_BOUNDARY_CC:-gcc}
# any header of the Modbus side's folder (gateway/modbus/), or libmodbus's
inc='#[[:space:]]*include[[:space:]]*[<"](modbus/[a-z_]+|modbus|regmap|mbproto|mbserver|mbrtu)\.h[>"]'
# Modbus's types, functions, constants and [modbus] settings.
mbsym='gw_unit_t|gw_status_t|gw_regmap_|gw_mb_|gw_mbs_|gw_mbap_|gw_rtu_|GW_EX_|GW_HR_|GW_LOSS_|GW_UNMAPPED_|GW_WORD_|modbus_|on_link_loss|on_loss|unmapped_read|word_order|single_writer'
fail=0
# FILE RULES: `inc` (no Modbus header) and, for the robot and the link, `sym`
# (no Modbus-side symbol, nor the [modbus] section: ->modbus / .modbus).
check() {
    f=$top/$1
    if [ ! -f "$f" ]; then echo "$label: $1 missing"; fail=1; return; fi
    # comments out, includes kept as written (-fpreprocessed -dD: no expansion)
    code=$("$cc" -fpreprocessed -dD -E -P -x c "$f" 2>/dev/null) || {
        echo "$label: cannot read $1"; fail=1; return; }
    hit=$(printf '%s\n' "$code" | grep -nE "$inc")
    if [ -n "$hit" ]; then echo "$label: $1 includes a Modbus header:"; echo "$hit"; fail=1; fi
    case $2 in *sym*)
        hit=$(printf '%s\n' "$code" | grep -nE "$mbsym|(->|\.)modbus\b")
        if [ -n "$hit" ]; then echo "$label: $1 names Modbus:"; echo "$hit"; fail=1; fi
    esac
    case $2 in *unit*)
        hit=$(printf '%s\n' "$code" | grep -nE 'gw_unit_t|gw_status_t|gw_regmap_|gw_mb_')
        if [ -n "$hit" ]; then echo "$label: $1 reads Modbus's units:"; echo "$hit"; fail=1; fi
    esac
}
check gateway/core/robot.h inc,sym
check gateway/core/robot.c inc,sym
check gateway/core/link.h inc,sym
check gateway/core/link.c inc,sym
check gateway/gpio/gpiomap.h inc,unit
check gateway/gpio/gpiomap.c inc,unit
check gateway/gpio/north_gpio.c inc,unit
check gateway/mqtt/north_mqtt.c inc,unit
check gateway/http/north_http.c inc,unit
check gateway/http/api.c inc,unit
check gateway/core/north.h inc,unit
check gateway/core/north.c inc,unit
if [ "$fail" -eq 0 ]; then
    echo "$label: clean"; echo "1 0 $label" >> "$results"
else
    echo "0 1 $label" >> "$results"
fi

# Sides plug in (docs/gateway.md "Adding a side", issue 30): the core
# (gateway/core/) includes no header of a side's folder and names no side's
# operations or section list; it reaches the sides through core/north.h and
# the side list gateway/sides.h, the only file that names them all. And a
# side does not reach into another side's folder but for the Modbus
# register map's own users (regmap.h is Modbus's); the console
# (gateway/http/) includes no other side's header. Nor does the core name a
# side's keys of [robot NAME] or their types (the Modbus side's unit_id,
# unit_id_alias, map, default_map_writes, fallback, gw_umap_t: its
# gw_modbus_robot_config_t, in the robot's side.modbus), nor reach into a
# side's member of a robot or of the configuration (->modbus, .modbus).
slabel="gateway side boundary (core knows sides only through north.h and sides.h)"
sfail=0
sides=$(cd "$top/gateway" && for d in */; do d=${d%/}; [ "$d" = core ] || [ "$d" = examples ] || printf '%s\n' "$d"; done)
sides_re=$(printf '%s\n' $sides | paste -sd'|' -)
# the Modbus side's keys of [robot NAME] (as names or as quoted key names)
# and its per-robot types
rkeys='\b(unit_id|alias0|alias255|fallback_hold|default_map_writes)\b|"(unit_id|unit_id_alias|map|default_map_writes|fallback)"|\bgw_umap_|\bGW_UMAP_|\bGW_MAX_MAP\b|\bGW_VIEW_|\bgw_view_t\b'
for f in "$top"/gateway/core/*.[ch]; do
    rel=${f#"$top"/}
    code=$("$cc" -fpreprocessed -dD -E -P -x c "$f" 2>/dev/null) || {
        echo "$slabel: cannot read $rel"; sfail=1; continue; }
    hit=$(printf '%s\n' "$code" | grep -nE "#[[:space:]]*include[[:space:]]*[<\"]($sides_re)/")
    if [ -n "$hit" ]; then echo "$slabel: $rel includes a side's header:"; echo "$hit"; sfail=1; fi
    hit=$(printf '%s\n' "$code" | grep -nE "gw_north_($sides_re)\b|gw_side_cfg_($sides_re)\b|gw_cfg_($sides_re)\b")
    if [ -n "$hit" ]; then echo "$slabel: $rel names a side:"; echo "$hit"; sfail=1; fi
    hit=$(printf '%s\n' "$code" | grep -nE "$rkeys|(->|\.)($sides_re)\b|gw_($sides_re)_(side_|robot_)?config_t")
    if [ -n "$hit" ]; then echo "$slabel: $rel names a side's robot keys or members:"; echo "$hit"; sfail=1; fi
done
# Within the list: every side folder, once each, and nothing else.
listed=$("$cc" -fpreprocessed -dD -E -P -x c "$top/gateway/sides.h" 2>/dev/null |
         grep -oE '^[[:space:]]*X\([a-z_0-9]+\)' | sed 's/.*X(\(.*\))/\1/' | sort | paste -sd' ' -)
folders=$(printf '%s\n' $sides | sort | paste -sd' ' -)
if [ "$listed" != "$folders" ]; then
    echo "$slabel: gateway/sides.h lists '$listed', the side folders are '$folders'"; sfail=1
fi
hit=$(cd "$top" && grep -nE '#[[:space:]]*include[[:space:]]*[<"](modbus|gpio|mqtt)/' gateway/http/*.[ch])
if [ -n "$hit" ]; then echo "$slabel: the console includes another side's header:"; echo "$hit"; sfail=1; fi
if [ "$sfail" -eq 0 ]; then
    echo "$slabel: clean"; echo "1 0 $slabel" >> "$results"
else
    echo "0 1 $slabel" >> "$results"; fail=1
fi

# The library's private headers (lib/*_internal.h: the wire toolkit, the
# client's parts, the field table) are for lib/ itself, drsim, the tests,
# fuzzers and benchmarks; the programs built on the public API (drcli,
# drgatewayd, common/) must not include them, although -I. would let them.
plabel="library boundary (no lib/*_internal.h in cli/, gateway/, common/)"
hit=$(cd "$top" && grep -rnE '#[[:space:]]*include[[:space:]]*[<"]([a-z/]*/)?[a-z_]+_internal\.h[>"]' cli gateway common |
      grep -vE '"(core/config_internal|gpio/gpio_internal)\.h"')
if [ -n "$hit" ]; then
    echo "$plabel: a private library header is included:"; echo "$hit"
    echo "0 1 $plabel" >> "$results"; fail=1
else
    echo "$plabel: clean"; echo "1 0 $plabel" >> "$results"
fi
[ "$fail" -eq 0 ]
