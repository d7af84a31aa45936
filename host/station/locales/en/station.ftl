# tapeshape station: operator text, English (complete; the fallback of
# every other language). Fluent syntax: https://projectfluent.org/
#
# Every key here must exist in every other locales/<lang>/station.ftl and
# every id the sources use must exist here (tests/i18n_catalogue.rs).
# Padding and the spaces around a message are the code's: Fluent trims a
# message's leading and trailing blanks.
# Fixed machine-readable words (line mode's `session`, `port`, `fault
# queue-full`, ...) are not here: they stay English in every language.

## Screens (top bar and titles)

screen-device = Device
screen-new-customer = New customer
screen-measuring = Measuring
screen-estimating = Estimating
screen-result = Result
screen-history = History

## Top bar, banner, help

top-session = session { $id } { $customer } { $set }
top-tape = tape:
top-demo-autopilot = DEMO autopilot
top-demo-manual = DEMO manual
banner-disconnected = TAPE DISCONNECTED: reconnecting... (d: details)
banner-disconnected-kept = TAPE DISCONNECTED: reconnecting... session kept, no reading lost (d: details)
banner-no-tape-kept = NO TAPE: plug it in; the session is kept (d: details)
help-title = Keys
help-anywhere = Anywhere
help-close = any key closes this help

## Keys as written in the footer and the help (single characters are
## written as they are)

key-ctrl-c = Ctrl-C
key-enter = Enter
key-esc = Esc
key-tab = Tab
key-shift-tab = S-Tab
key-left-right = <-/->
key-up-down = up/down
key-backspace = Backspace
key-del = Del
key-any = any key
key-any-other = any other key

## Keys that work anywhere

global-quit-now-help = quit at once
global-help = help
global-help-help = this help (any key closes it)
global-device = device
global-device-help = the device screen: the tape's connection, versions and faults
global-history = history
global-history-help = the history of sessions
global-quit = quit
global-quit-help = quit, pressed twice (every reading taken is already stored)

## Notices

notice-taken-over = You have the keyboard: the simulated operator stopped (? for keys)
notice-quit-again = Press q again to quit (every reading taken is already stored)
notice-gap = Tape sent reading { $got } before { $expected }: waiting for it to resend
notice-unassigned = The tape holds a reading ({ $value }): it is kept on the tape until a measurement is chosen
notice-commit-failed = Could not store { $value } ({ $error }); the tape keeps it

## Device screen

device-title = Tape
device-port = port
device-state = state
device-why = why
device-id = device id
device-boot = boot
device-firmware = firmware
device-protocol = protocol
device-device = device
device-no-hello = no hello yet
device-host = host
device-host-value = tapeshape { $version } protocol { $protocol }
device-queue = tape queue
device-queue-value = { $n } of { $capacity } unacknowledged
device-link = link
device-link-value = { $bad } bad frames, { $lost } connections lost
device-live = live
device-faults = Recent faults
device-no-faults = none
device-back = back
device-back-help = back to the screen before (also b or d)
device-reconnected = Tape reconnected: carry on (readings it held are being stored)
connection-starting = starting
connection-waiting = no tape (waiting)
connection-port-open = port open, handshake
connection-connected = connected
connection-mismatch = WRONG VERSION
connection-disconnected = DISCONNECTED
connection-stopped = stopped

## Device faults (after the fault's fixed word, e.g. `queue-full:`)

fault-queue-full = the tape's queue ({ $capacity }) is full; { $value } was NOT recorded, take it again
fault-queue-recovered = { $held } held
fault-tape-silent = no line from the tape for { $seconds } s; check its cable
fault-line-rejected = the tape sent { $what } ({ $total } since boot); if this repeats, check the tape's cable
fault-version-mismatch = the tape speaks protocol { $device }, it was greeted with { $host }
fault-host-frame-bad = the tape dropped a frame from us ({ $total } since boot)
reject-garbage = something that is not a tape line
reject-partial = a cut-off line ({ $len } of 19 characters)
reject-overlong = a line longer than 19 characters
reject-bad-field = a line whose field { $field } is not what a tape sends
reject-negative = a negative length
reject-out-of-range = a length it cannot measure ({ $value })

## Finding the tape (tapeshape station without --port; the kiosk's words,
## the line mode's stay English)

search-nothing-answered = No tape station answered. Plug the tape station's USB cable into this computer (on the nRF52840-DK: the nRF USB connector, not the debug one).
search-no-ports = No serial ports are attached.
search-ports-seen = Serial ports seen:
search-several = { $n } tape stations answered. Which one is this station's tape?
search-press-number = Press its number; q leaves.
search-looking-again = Looking again every second; q leaves.
probe-answered = tape station { $device } answered (boot { $boot }, firmware { $firmware }, protocol { $protocol })
probe-incompatible = tape station { $device } answered in protocol { $protocol } (firmware { $firmware }), but this program speaks { $host }: update the older of the two
probe-not-probed = not probed: another kind of device (`tapeshape ports --probe-all` tries it, `--port PATH` uses it)
probe-silent = no answer within { $ms } ms (not a tape station, or its firmware is not running)
probe-not-the-protocol = sent { $bytes } bytes in { $ms } ms that are not the tapeshape protocol ({ $bad } bad frames): another kind of device
probe-no-hello = sent { $frames } protocol frames but no hello within { $ms } ms
probe-permission-denied = permission denied: add this user to the port's group (on Debian and Ubuntu `sudo usermod -aG dialout $USER`, then log in again)
probe-busy = busy: another program has it open (another tapeshape station?)
probe-gone = no such port (unplugged?)
probe-open-failed = cannot open it: { $error }
probe-io = failed while probing: { $error }
probe-debug-port = this is the board's debug (J-Link) port: the station talks on the nRF USB port

## New customer screen

new-customer-title = New customer
form-customer = customer id
form-customer-help = opaque; no name needed
form-sex = sex
form-sex-help = f / m
form-age = age (optional)
form-age-help = years
form-set = measurements
form-set-help = <- -> to choose
form-custom-file = custom file
form-file = set file
form-file-help = TOML file
form-readings = readings
form-readings-help = 1 once / 2 twice (careful)
readings-once = each once
readings-twice = each twice (careful)
form-once-help = Take each measurement once
form-twice-help = Take each measurement twice, a third when they differ (careful mode)
form-consent = their data
form-consent-help = ask them: k keep / v visit
form-file-blurb = a measurement set file (TOML, as host/measure/sets/*.toml)
form-enter-starts = Enter starts the session; readings are stored as they are taken.
sex-none = not given
sex-female = female
sex-male = male
consent-keep = keep my data
consent-visit = this visit only
set-blurb = { $name }: { $count } measurements. { $description }
set-description-quick = The fitting-room set (about two minutes with one tape): stature, chest/bust, waist at the navel, hip, neck, inside leg, arm length, thigh and upper arm.
set-description-ansur = ANSUR II dimensions that can be taken on a standing body (heights, breadths, depths, girths, segment lengths, arcs), each named by its ANSUR column, for checking predictions against real people.
set-description-paper34 = The paper's 34 body measurements (14 lengths, hip/waist/chest/head circumferences, knee and arm loops of 4 geodesics each): the set the method was published with, for reproducing its experiments.
form-error-customer = Give a customer id (any text; a new one is suggested)
form-error-age = Age { $age } is not between 16 and 110: correct it or leave it empty
form-error-file = Give the path of the measurement set file (TOML)
form-next-field = field
form-next-field-help = next field (also down)
form-previous-field-help = previous field (also up)
form-choose = choose
form-choose-help = choose the sex, the measurement set or the data choice
form-start = start
form-start-help = start the session; readings are stored as they are taken
form-female-key = f
form-female-help = female
form-male-help = male
form-delete-char-help = delete the last character typed
form-keep-help = keep my data (the chain keeps the sessions until the customer asks to erase them)
form-visit-help = this visit only (purged after the hub's retention period)
resume-key = y
resume-title = Resume?
resume-resume = resume
resume-resume-help = resume
resume-new = new customer
resume-new-help = start a new customer
resume-close-help = close the offer (the session stays open; find it under h)
resume-not-finished = Session { $session } (customer { $customer }, { $set }) is not finished:
resume-no-set = no set
resume-readings = { $n } readings are stored. Resume it with them?
resume-declined = Session { $session } stays open; find it under h (history)

## Measurements of the quick set (the measuring flow): the operator's names

measure-quick-stature = Height
measure-quick-chest = Chest / bust
measure-quick-waist = Waist (at the navel)
measure-quick-hip = Hip
measure-quick-neck = Neck (base)
measure-quick-inside_leg = Inside leg
measure-quick-arm_length = Arm length
measure-quick-thigh = Thigh
measure-quick-upper_arm = Upper arm

## Instructions of the quick set's measurements (the measuring screen)

measure-quick-stature-how = Customer standing erect against the wall, heels together, head level, shoes off. Floor to the top of the head.
measure-quick-chest-how = Customer standing, arms relaxed, breathing quietly. Tape horizontal around the chest at nipple (bust point) level, passing under the armpits, arms outside the tape. For women this is the full bust.
measure-quick-waist-how = Customer standing erect, relaxed, breathing quietly. Tape horizontal around the trunk at the level of the navel. This is the navel waist used by ANSUR, not the narrowest part of the trunk.
measure-quick-hip-how = Customer standing erect, heels together. Tape horizontal around the hips over the most prominent point of the buttocks.
measure-quick-neck-how = Customer standing, head level. Tape around the base of the neck: over the bone at the back of the neck base (C7), the sides of the neck where it meets the shoulders, and the notch at the top of the breastbone.
measure-quick-inside_leg-how = Customer standing erect, heels together. Vertical distance from the floor to the crotch (use a rule or the tape held vertically on the inside of the right leg).
measure-quick-arm_length-how = Customer standing, right arm straight at the side. Tape from the tip of the shoulder (acromion) over the outer elbow point down to the wrist bone on the thumb side (stylion).
measure-quick-thigh-how = Customer standing, feet slightly apart so the thighs do not touch. Tape around the right thigh just below the buttock crease, perpendicular to the thigh.
measure-quick-upper_arm-how = Customer standing, right arm relaxed. Tape around the upper arm at mid-biceps level (halfway between shoulder tip and elbow), perpendicular to the arm.

## Measuring screen

measuring-hold-key = hold
measuring-hold-help = the tape's hold button stores the reading
measuring-move-help = choose a measurement in the list (also k / j)
measuring-capture = capture
measuring-capture-help = store the tape's live value; on a flagged reading: keep it
measuring-retake = retake
measuring-retake-help = retake the selected measurement (also Space)
measuring-skip = skip
measuring-skip-help = skip the current measurement
measuring-undo = undo
measuring-undo-help = undo the last step (stored readings stay in the history)
measuring-units = cm/in
measuring-units-help = show lengths in centimetres or inches
measuring-estimate = estimate
measuring-estimate-help = estimate the body from the readings taken
measuring-new-customer-help = a new customer (this session stays open)
measuring-sim-tape = sim tape
measuring-sim-tape-help = the simulated tape measures the current measurement
measuring-sim-slip-help = ... read off the inch scale (a unit slip)
measuring-no-session = No session
measuring-list-title = { $taken } of { $total } taken
measuring-now = Now: { $name }
measuring-tape-label = Tape
measuring-stored-label = Stored
measuring-earlier = earlier { $values }
measuring-careful = Careful
measuring-flagged-what-now = Measure again (hold the tape), or Enter to keep this value
measuring-checking = Checking the reading...
measuring-retake-hint = Retake: hold the tape to replace the stored value
measuring-hold-hint = Hold the tape's button to capture (or Enter)
measuring-done-title = Done
measuring-all-done = Every measurement is taken or skipped.
measuring-done-estimate = estimate the body
measuring-done-retake = retake the selected one
measuring-flagged-others = Flagged: { $names }
measuring-skipped-count = { $n } skipped
measuring-live-body = body so far
measuring-live-updating = updating...
measuring-live-no-body = no body yet
measuring-live-readings = { $n ->
    [one] { $n } reading
   *[other] { $n } readings
  }
# Notices of the measuring screen
measuring-undo-skipped = skipped { $name }
measuring-undo-retake = retake of { $name }
measuring-undo-kept = kept flagged { $name }
measuring-undo-reading = reading of { $name }
measuring-undone = Undone: { $what } (stored readings stay in the session's history)
measuring-nothing-to-undo = Nothing to undo
measuring-nothing-left = Nothing left to measure
measuring-skipped = Skipped { $name } (u undoes)
measuring-retaking = Retake { $name }: measure again and hold the tape
measuring-all-taken-press-e = Every measurement is taken: press e to estimate
measuring-kept-flagged = Kept the flagged { $name } reading
measuring-no-tape-value = No tape value to capture: pull the tape out (or press its hold button)
measuring-opened = Session { $id } opened with its { $n ->
    [one] { $n } stored reading
   *[other] { $n } stored readings
  }
measuring-opened-unknown = Session { $id } opened with its { $n ->
    [one] { $n } stored reading
   *[other] { $n } stored readings
  } ({ $unknown } not in its set: { $names })
measuring-no-stored-estimate = Session { $id } has no stored estimate: press e to estimate it
measuring-stored-not-in-set = Stored { $value } as { $name } (not in this set)
measuring-stored = Stored { $name } = { $value }
measuring-stored-careful-kept = Stored { $name } = { $value }; kept { $kept }, the median of this round
measuring-stored-careful-again = Stored { $name } = { $value }; { $status }: measure it again
measuring-stored-retake = retake; was { $was }
measuring-stored-inches = tape showing inches
measuring-flag-far-off = { $name }: far off. Measure again, or Enter to keep it
measuring-flag-unit-slip = { $name }: unit slip? Measure again, or Enter to keep it
measuring-all-taken = All measurements taken: press e to estimate the body
measuring-all-taken-marked = All measurements taken ({ $skipped } skipped, { $flagged } flagged): press e to estimate the body
measuring-no-readings = No readings yet: take at least one measurement before estimating
measuring-still-checking = A reading is still being checked; try again
# Careful mode's status line (ISO 20685-1: each measurement twice, a third
# when the two differ by more than the allowable error)
careful-first = reading 1 of { $needed }
careful-next = reading { $n } of { $needed } (so far { $so_far })
careful-third-needed = third reading needed: the two differ by { $apart } (allowed { $allowed })
careful-kept = kept { $value } (the median of { $readings })

## Checking a reading (the measuring screen's line after "!"; the line mode
## and `tapeshape check` keep the English sentence with the measurement's name)

check-source-people = what is typical for people
check-source-population = what is typical for the model's population
check-source-other = what the other reading predicts
check-source-others = what the other readings predict
check-fits = { $name } { $value } { $unit } fits { $source } { $prediction }
check-warn-above = { $name } { $value } { $unit } is { $z } SD above { $source } { $prediction }: check it
check-warn-below = { $name } { $value } { $unit } is { $z } SD below { $source } { $prediction }: check it
check-flag-above = { $name } { $value } { $unit } is { $z } SD above { $source } { $prediction }: measure again
check-flag-below = { $name } { $value } { $unit } is { $z } SD below { $source } { $prediction }: measure again
check-flag-above-refused = { $name } { $value } { $unit } is { $z } SD above { $source } { $prediction }: measure again (the estimate will refuse it)
check-flag-below-refused = { $name } { $value } { $unit } is { $z } SD below { $source } { $prediction }: measure again (the estimate will refuse it)
check-unit-slip = { $name } { $value } { $unit } fits { $number } { $other } ({ $metres } { $unit }): check the tape's unit
check-not-checked = { $name } not checked: { $error }

## Estimating screen

estimating-title = Estimating the body
stage-check = check readings
stage-start = first guess (feature analysis)
stage-step1 = fit shape space
stage-step2 = refine surface
stage-done = done
estimating-refused = The estimate was refused:
estimating-refused-back = Esc goes back to measuring: retake the readings named above.
estimating-cancelling = Cancelling...
estimating-fitting = Fitting the body to { $n ->
    [one] { $n } reading
   *[other] { $n } readings
  }; Esc cancels.
estimating-cancel = cancel
estimating-cancel-help = cancel the estimate (the readings stay as they are)
estimating-back = back to measuring
estimating-back-help = back to measuring
estimating-cancelled = Estimate cancelled; the readings are unchanged

## Result screen

result-export = export
result-export-help = export the body and report.json (the session is marked done)
result-format = format
result-format-help = the export's format: GLB, OBJ or PLY
result-card = card
result-card-help = the customer's card: a PDF with the body, the readings and the sizes, written beside the exports (the session stays as it is)
result-back = back
result-back-help = back to measuring (also Esc)
result-next-customer = next customer
result-next-customer-help = the next customer (this session is marked done)
result-none = No estimate yet: press e on the measuring screen
result-front = front
result-side = side
result-title = Estimate ({ $seconds } s)
result-col-measurement = measurement
result-col-target = target
result-col-body = body
result-col-error-mm = err mm
result-col-error-in = err in
result-plausibility = plausibility
result-plausibility-value = { $shape } body (mahalanobis { $body }), readings { $readings } ({ $distance })
plausibility-typical = typical
plausibility-unusual = unusual
plausibility-implausible = implausible
result-careful = careful
result-tem = TEM { $tem } mm ({ $percent } %) over { $pairs } measurement pairs
result-more-warnings = +{ $n } more
result-exported = exported { $files }
result-exported-in = in { $dir }
result-export-hint = exports { $format } + report.json
result-other-format = other format
result-card-file = card { $file }
result-exporting = Exporting...
result-writing-card = Writing the card...
result-stored = Estimate stored { $time }
result-stored-earlier = Estimate stored { $time }, before the last change to the readings: b, then e, estimates again
result-exported-notice = Exported { $n } files to { $dir }
result-export-failed = Export failed: { $error }
result-card-written = Card written to { $path }
result-card-failed = The card was not written: { $error }; the session and its estimate are kept
# The Sizes box (garment names and size labels are the chart's own)
result-sizes = Sizes
sizes-best = { $garment }: { $size } ({ $percent } %)
sizes-or = or { $size }
sizes-no-size = { $garment }: no size ({ $missing } not known)
sizes-none = no sizes: { $error }
sizes-none-report = no sizes: the stored report cannot be read ({ $error })
sizes-tight = tight at the { $place }
sizes-loose = loose at the { $place }
sizes-too-short = too short for the { $place }
sizes-too-long = too long for the { $place }
sizes-narrow = narrow at the { $place }
sizes-wide = wide at the { $place }

## History screen

history-title = Sessions ({ $n })
history-title-loading = Sessions (loading...)
history-col-id = id
history-col-customer = customer
history-col-set = set
history-col-status = status
history-col-readings = rd
history-col-updated = updated (UTC)
history-empty = No sessions stored yet
status-open = open
status-done = done
status-abandoned = abandoned
history-confirm-delete = delete
history-confirm-delete-help = delete it for good
history-keep = keep
history-keep-help = keep it
history-keep-it = keep it
history-move-help = choose a session in the list (also k / j)
history-reopen = reopen
history-reopen-help = reopen the session to measure (also o)
history-result = result
history-result-help = show its stored estimate (nothing is estimated again)
history-estimate = estimate
history-estimate-help = estimate the session again
history-export = export
history-export-help = export it (its stored estimate if that is of its readings)
history-delete = delete
history-delete-help = delete the session (asks first; also D)
history-back = back
history-back-help = back to the screen before (also b)
history-reload-help = load the list again
history-deleted = Session { $id } deleted
history-kept = Kept the session
history-delete-title = Delete?
history-delete-question = Delete session { $id } ({ $customer }, { $readings } readings, { $retaken } retaken) for good?

## The runner (what failed, and what to do)

run-keyboard-failed = reading the keyboard: { $error }; restart the station
run-open-failed = opening session { $id }: { $error }
run-capture-failed = storing the captured value: { $error }
run-no-stored-estimate = session { $session } has no stored estimate: press e to estimate it
run-withdraw-failed = withdrawing reading { $id }: { $error }
run-mark-failed = storing the mark on { $name }: { $error }
run-status-failed = marking session { $id } { $status }: { $error }
run-list-failed = reading the sessions: { $error }
run-delete-failed = deleting session { $id }: { $error }
run-no-sim-tape = there is no simulated tape outside the demo
run-terminal-failed = setting up the terminal
run-keyboard-thread-failed = starting the keyboard thread
run-log-open-failed = opening the log file { $path }
run-log-written = log messages of this run: { $path }
run-internal-error = the interface stopped on an internal error (details in { $path }); every reading taken is stored: start again and resume the session

## The demo's simulated tape

sim-no-value = the simulated customer has no value for { $name }; take it with Enter instead
sim-stopped = the simulated tape stopped; start the demo again

## The estimate's warnings (result screen, predict, session show). Each
## says what the English report's text says (a test holds them together).

warn-no-unit = no unit given for { $names }: read as { $unit }
warn-unit-mm = millimetres
warn-unit-cm = centimetres
warn-unit-m = metres
warn-unit-in = inches
warn-kept = kept by the operator: { $what }
warn-check-reading = { $what }: check this reading
warn-out-of-range-above = { $name } { $typed } ({ $cm } cm) is { $z } SD above the population the model knows (typical: { $typical }): check the reading and its unit
warn-out-of-range-below = { $name } { $typed } ({ $cm } cm) is { $z } SD below the population the model knows (typical: { $typical }): check the reading and its unit
warn-unit-slip = { $name } { $typed } looks like { $unit }: write { $number }{ $symbol } (typical: { $typical })
warn-unit-slip-bare = { $name } { $typed } looks like { $unit }: write { $number }{ $symbol } (typical: { $typical }); a number without a unit is read as { $bare }
warn-others-more = { $list } and { $n } more
warn-against-one-above = { $name } { $cm } cm is { $z } SD above what { $others } predicts ({ $mu } +/- { $sd } cm)
warn-against-others-above = { $name } { $cm } cm is { $z } SD above what { $others } predict ({ $mu } +/- { $sd } cm)
warn-against-one-below = { $name } { $cm } cm is { $z } SD below what { $others } predicts ({ $mu } +/- { $sd } cm)
warn-against-others-below = { $name } { $cm } cm is { $z } SD below what { $others } predict ({ $mu } +/- { $sd } cm)
warn-unusual-set = unusual set of measurements (Mahalanobis distance { $distance } over { $n } readings, { $percent }% of the population is closer to the mean): the result is plausible but check the readings
warn-estimated-with-kept = estimated with unusual readings the operator kept ({ $names }): the body fits them as far as a human-looking surface allows; the set's plausibility: { $percent }% of the training population is closer to the mean (Mahalanobis distance { $distance })
warn-recorded-not-fitted = { $n ->
    [one] { $n } reading recorded, not fitted: { $names }: the standing body model cannot take it as ANSUR II defines it (flexed girths, calipers that compress the tissue), so the body does not follow it; the reading is kept in the report beside the body's own value
   *[other] { $n } readings recorded, not fitted: { $names }: the standing body model cannot take them as ANSUR II defines them (flexed girths, calipers that compress the tissue), so the body does not follow them; the readings are kept in the report beside the body's own value
}
warn-recorded-sum-of-parts = { $name } recorded, not fitted: on the body it is the sum of { $parts }, which are fitted; ANSUR II takes it with another instrument and posture (about 10 mm shorter than that sum), so fitting all of them would ask the body for a contradiction; the reading is kept in the report beside the body's own value
warn-stage-step1 = step 1
warn-stage-step2 = step 2
warn-solver-stopped = { $stage } round { $round }: optimiser stopped: { $reason }
warn-zero-length = { $stage }: measurement '{ $name }' has zero length on the current shape and was left out of this round
warn-objective-map = MAP objective
warn-objective-energy = measurement energy E_m (mm^4)
warn-step1-kept-start = step 1 ended with a higher { $objective } than the start ({ $end } vs { $start }): kept the start shape
warn-step2-kept-round = step 2 ended with a higher measurement energy than step 1 (E_m { $end } vs { $step1 } mm^4): kept its shape at the start of round { $round } (E_m { $kept })
warn-step2-kept-step1 = step 2 ended with a higher measurement energy than step 1 (E_m { $end } vs { $step1 } mm^4): kept the step-1 shape
warn-triangles = step 2 flipped { $flipped } and collapsed { $collapsed } triangles: the measurements may be inconsistent
warn-step1-smoothed = the shape space's fit folded { $folded } triangles of the surface: smoothed them out before refining, { $left } left
warn-folds-smoothed = step 2 folded { $folded } triangles of the surface: smoothed them out, { $left } left
warn-surface-over-readings = { $folded } triangles of the surface stayed folded where the body met the readings: smoothed them out, { $left } left; these readings are now outside their allowable error: { $names }
warn-surface-over-readings-none = { $folded } triangles of the surface stayed folded where the body met the readings: smoothed them out, { $left } left; no reading left its allowable error
warn-soft-pull-reduced = following real people's statistics for the dimensions not measured { $asked } % of the way folded or creased the surface: followed them { $pull } %
warn-far-from-population = the measurements are far from the training population (Mahalanobis distance { $distance } over { $n } measurements): the shape is held to { $sd } SD and may not fit them all
warn-not-fitted = '{ $name }' could not be fitted within { $limit } mm (error { $error } mm)
warn-measuring-failed = measuring the measurements not given failed: { $reason }
refuse-kept-beyond = { $what }; kept by the operator, but beyond any person
refuse-contradiction = the readings contradict each other: { $list }; re-take these readings, or keep them if they are right (the estimate then fits them as far as a human-looking body allows)
