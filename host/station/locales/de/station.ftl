# tapeshape station: Bedientexte, Deutsch. Fluent syntax:
# https://projectfluent.org/
#
# The keys are those of locales/en/station.ftl, every one of them
# (tests/i18n_catalogue.rs checks it); a key missing here would show the
# English text. Fixed machine-readable words (line mode's `session`,
# `port`, `fault queue-full`, ...) stay English and are not here.

## Screens (top bar and titles)

screen-device = Gerät
screen-new-customer = Neuer Kunde
screen-measuring = Messung
screen-estimating = Berechnung
screen-result = Ergebnis
screen-history = Verlauf

## Top bar, banner, help

top-session = Sitzung { $id } { $customer } { $set }
top-tape = Maßband:
top-demo-autopilot = DEMO Autopilot
top-demo-manual = DEMO manuell
banner-disconnected = MASSBAND GETRENNT: verbinde neu... (d: Details)
banner-disconnected-kept = MASSBAND GETRENNT: verbinde neu... Sitzung bleibt, kein Messwert verloren (d: Details)
banner-no-tape-kept = KEIN MASSBAND: bitte anschließen; die Sitzung bleibt (d: Details)
help-title = Tasten
help-anywhere = Überall
help-close = jede Taste schließt diese Hilfe

## Keys as written in the footer and the help

key-ctrl-c = Strg-C
key-enter = Enter
key-esc = Esc
key-tab = Tab
key-shift-tab = Umsch-Tab
key-left-right = <-/->
key-up-down = hoch/runter
key-backspace = Rücktaste
key-del = Entf
key-any = jede Taste
key-any-other = jede andere Taste

## Keys that work anywhere

global-quit-now-help = sofort beenden
global-help = Hilfe
global-help-help = diese Hilfe (jede Taste schließt sie)
global-device = Gerät
global-device-help = der Gerätebildschirm: Verbindung, Versionen, Fehler des Maßbands
global-history = Verlauf
global-history-help = der Verlauf der Sitzungen
global-quit = Ende
global-quit-help = beenden, zweimal drücken (jeder Messwert ist schon gespeichert)

## Notices

notice-taken-over = Sie haben die Tastatur: der simulierte Bediener hat aufgehört (? für Tasten)
notice-quit-again = Nochmals q zum Beenden (jeder Messwert ist schon gespeichert)
notice-gap = Das Maßband schickte Messwert { $got } vor { $expected }: warte, bis es ihn neu sendet
notice-unassigned = Das Maßband hält einen Messwert ({ $value }): er bleibt dort, bis eine Messung gewählt ist
notice-commit-failed = { $value } konnte nicht gespeichert werden ({ $error }); das Maßband behält ihn

## Device screen

device-title = Maßband
device-port = Anschluss
device-state = Zustand
device-why = Grund
device-id = Geräte-ID
device-boot = Start
device-firmware = Firmware
device-protocol = Protokoll
device-device = Gerät
device-no-hello = noch keine Begrüßung
device-host = Rechner
device-host-value = tapeshape { $version } Protokoll { $protocol }
device-queue = Warteschlange
device-queue-value = { $n } von { $capacity } unbestätigt
device-link = Verbindung
device-link-value = { $bad } fehlerhafte Rahmen, { $lost ->
    [one] 1 Verbindung verloren
   *[other] { $lost } Verbindungen verloren
  }
device-live = aktuell
device-faults = Letzte Fehler
device-no-faults = keine
device-back = zurück
device-back-help = zurück zum vorigen Bildschirm (auch b oder d)
device-reconnected = Maßband wieder verbunden: weitermachen (gehaltene Messwerte werden gespeichert)
connection-starting = startet
connection-waiting = kein Maßband (warte)
connection-port-open = Anschluss offen, Begrüßung
connection-connected = verbunden
connection-mismatch = FALSCHE VERSION
connection-disconnected = GETRENNT
connection-stopped = gestoppt

## Device faults (after the fault's fixed word, e.g. `queue-full:`)

fault-queue-full = die Warteschlange des Maßbands ({ $capacity }) ist voll; { $value } wurde NICHT gespeichert, bitte neu messen
fault-queue-recovered = { $held } gehalten
fault-tape-silent = seit { $seconds } s keine Zeile vom Maßband; Kabel prüfen
fault-line-rejected = das Maßband schickte { $what } ({ $total } seit dem Start); wenn das wieder vorkommt, Kabel prüfen
fault-version-mismatch = das Maßband spricht Protokoll { $device }, begrüßt wurde es mit { $host }
fault-host-frame-bad = das Maßband verwarf einen Rahmen von uns ({ $total } seit dem Start)
reject-garbage = etwas, das keine Maßbandzeile ist
reject-partial = eine abgeschnittene Zeile ({ $len } von 19 Zeichen)
reject-overlong = eine Zeile mit mehr als 19 Zeichen
reject-bad-field = eine Zeile, deren Feld { $field } nicht ist, was ein Maßband sendet
reject-negative = eine negative Länge
reject-out-of-range = eine Länge, die es nicht messen kann ({ $value })

## Finding the tape (tapeshape station without --port; the kiosk's words,
## the line mode's stay English)

search-nothing-answered = Kein Maßband hat geantwortet. Das USB-Kabel des Maßbands an diesen Rechner anschließen (beim nRF52840-DK: die nRF-USB-Buchse, nicht die Debug-Buchse).
search-no-ports = Keine seriellen Anschlüsse vorhanden.
search-ports-seen = Gesehene serielle Anschlüsse:
search-several = { $n } Maßbänder haben geantwortet. Welches gehört zu dieser Station?
search-press-number = Seine Nummer drücken; q beendet.
search-looking-again = Sucht jede Sekunde erneut; q beendet.
probe-answered = Maßband { $device } hat geantwortet (Start { $boot }, Firmware { $firmware }, Protokoll { $protocol })
probe-incompatible = Maßband { $device } antwortete mit Protokoll { $protocol } (Firmware { $firmware }), dieses Programm spricht { $host }: das ältere der beiden aktualisieren
probe-not-probed = nicht geprüft: ein anderes Gerät (`tapeshape ports --probe-all` versucht es, `--port PATH` nimmt es)
probe-silent = keine Antwort in { $ms } ms (kein Maßband, oder seine Firmware läuft nicht)
probe-not-the-protocol = schickte { $bytes } Bytes in { $ms } ms, die nicht das tapeshape-Protokoll sind ({ $bad } fehlerhafte Rahmen): ein anderes Gerät
probe-no-hello = schickte { $frames } Protokollrahmen, aber keine Begrüßung in { $ms } ms
probe-permission-denied = keine Berechtigung: diesen Benutzer zur Gruppe des Anschlusses hinzufügen (unter Debian und Ubuntu `sudo usermod -aG dialout $USER`, dann neu anmelden)
probe-busy = belegt: ein anderes Programm hat ihn offen (eine andere tapeshape-Station?)
probe-gone = kein solcher Anschluss (abgesteckt?)
probe-open-failed = lässt sich nicht öffnen: { $error }
probe-io = Fehler beim Prüfen: { $error }
probe-debug-port = das ist der Debug-Anschluss (J-Link) der Platine: die Station spricht über den nRF-USB-Anschluss

## New customer screen

new-customer-title = Neuer Kunde
form-customer = Kunden-ID
form-customer-help = anonym; kein Name nötig
form-sex = Geschlecht
form-sex-help = w / m
form-age = Alter
form-age-help = Jahre (freiwillig)
form-set = Messungen
form-set-help = <- -> zum Wählen
form-custom-file = eigene Datei
form-file = Messdatei
form-file-help = TOML-Datei
form-readings = Messwerte
form-readings-help = 1 einmal / 2 zweimal (sorgfältig)
readings-once = je einmal
readings-twice = je zweimal (sorgfältig)
form-once-help = Jedes Maß einmal nehmen
form-twice-help = Jedes Maß zweimal nehmen, ein drittes Mal bei Abweichung (sorgfältiger Modus)
form-consent = Ihre Daten
form-consent-help = fragen: k behalten / v nur Besuch
form-file-blurb = eine Datei mit Messungen (TOML, wie host/measure/sets/*.toml)
form-enter-starts = Enter startet die Sitzung; Messwerte werden sofort gespeichert.
sex-none = keine Angabe
sex-female = weiblich
sex-male = männlich
consent-keep = Daten behalten
consent-visit = nur dieser Besuch
set-blurb = { $name }: { $count } Messungen. { $description }
set-description-quick = Der Satz für die Umkleide (etwa zwei Minuten mit einem Maßband): Körperhöhe, Brustumfang, Taillenumfang auf Nabelhöhe, Hüftumfang, Halsumfang, Innenbeinlänge, Armlänge, Oberschenkel- und Oberarmumfang.
set-description-ansur = ANSUR-II-Maße, die am stehenden Körper genommen werden können (Höhen, Breiten, Tiefen, Umfänge, Segmentlängen, Bögen), je nach ihrer ANSUR-Spalte benannt, um Vorhersagen an echten Menschen zu prüfen.
set-description-paper34 = Die 34 Körpermaße des Artikels (14 Längen, Hüft-, Taillen-, Brust- und Kopfumfang, Knie- und Armschlingen aus je 4 Geodäten): der Satz, mit dem die Methode veröffentlicht wurde, um ihre Versuche nachzuvollziehen.
form-error-customer = Bitte eine Kunden-ID angeben (beliebiger Text; eine neue ist vorgeschlagen)
form-error-age = Alter { $age } liegt nicht zwischen 16 und 110: korrigieren oder leer lassen
form-error-file = Bitte den Pfad der Messdatei (TOML) angeben
form-next-field = Feld
form-next-field-help = nächstes Feld (auch runter)
form-previous-field-help = voriges Feld (auch hoch)
form-choose = wählen
form-choose-help = Geschlecht, Messungen oder Datenwahl wählen
form-start = Start
form-start-help = die Sitzung starten; Messwerte werden sofort gespeichert
form-female-key = w
form-female-help = weiblich
form-male-help = männlich
form-delete-char-help = das zuletzt getippte Zeichen löschen
form-keep-help = Daten behalten (die Kette behält die Sitzungen, bis der Kunde die Löschung verlangt)
form-visit-help = nur dieser Besuch (nach der Aufbewahrungsfrist der Zentrale gelöscht)
resume-key = j
resume-title = Fortsetzen?
resume-resume = fortsetzen
resume-resume-help = fortsetzen
resume-new = neuer Kunde
resume-new-help = einen neuen Kunden beginnen
resume-close-help = das Angebot schließen (die Sitzung bleibt offen; unter h zu finden)
resume-not-finished = Sitzung { $session } (Kunde { $customer }, { $set }) ist nicht fertig:
resume-no-set = keine Messungen
resume-readings = { $n ->
    [one] 1 Messwert ist gespeichert. Mit ihm fortsetzen?
   *[other] { $n } Messwerte sind gespeichert. Mit ihnen fortsetzen?
  }
resume-declined = Sitzung { $session } bleibt offen; unter h (Verlauf) zu finden

## Measurements of the quick set (the measuring flow): the operator's names

measure-quick-stature = Körperhöhe
measure-quick-chest = Brustumfang
measure-quick-waist = Taille (Nabelhöhe)
measure-quick-hip = Hüftumfang
measure-quick-neck = Halsumfang (Ansatz)
measure-quick-inside_leg = Innenbeinlänge
measure-quick-arm_length = Armlänge
measure-quick-thigh = Oberschenkelumfang
measure-quick-upper_arm = Oberarmumfang

## Instructions of the quick set's measurements (the measuring screen)

measure-quick-stature-how = Kunde steht aufrecht an der Wand, Fersen zusammen, Kopf gerade, ohne Schuhe. Vom Boden bis zum Scheitel.
measure-quick-chest-how = Kunde steht, Arme locker, atmet ruhig. Band waagerecht um die Brust auf Höhe der Brustwarzen, unter den Achseln hindurch, Arme außerhalb des Bandes. Bei Frauen ist das die volle Brust.
measure-quick-waist-how = Kunde steht aufrecht, locker, atmet ruhig. Band waagerecht um den Rumpf auf Höhe des Nabels. Das ist die Nabeltaille von ANSUR, nicht die schmalste Stelle des Rumpfes.
measure-quick-hip-how = Kunde steht aufrecht, Fersen zusammen. Band waagerecht um die Hüften über die stärkste Stelle des Gesäßes.
measure-quick-neck-how = Kunde steht, Kopf gerade. Band um den Halsansatz: über den Knochen hinten am Halsansatz (C7), die Halsseiten, wo sie auf die Schultern treffen, und die Kerbe oben am Brustbein.
measure-quick-inside_leg-how = Kunde steht aufrecht, Fersen zusammen. Senkrechter Abstand vom Boden bis zum Schritt (mit einem Lineal oder dem senkrecht gehaltenen Band an der Innenseite des rechten Beins).
measure-quick-arm_length-how = Kunde steht, rechter Arm gestreckt an der Seite. Band von der Schulterspitze (Akromion) über den äußeren Ellbogenpunkt bis zum Handgelenkknochen auf der Daumenseite (Stylion).
measure-quick-thigh-how = Kunde steht, Füße leicht auseinander, sodass sich die Oberschenkel nicht berühren. Band um den rechten Oberschenkel direkt unter der Gesäßfalte, quer zum Oberschenkel.
measure-quick-upper_arm-how = Kunde steht, rechter Arm locker. Band um den Oberarm auf halber Bizepshöhe (zwischen Schulterspitze und Ellbogen), quer zum Arm.

## Measuring screen

measuring-hold-key = Halten
measuring-hold-help = die Haltetaste des Maßbands speichert den Messwert
measuring-move-help = eine Messung der Liste wählen (auch k / j)
measuring-capture = übernehmen
measuring-capture-help = den aktuellen Wert des Maßbands speichern; bei einem markierten Messwert: ihn behalten
measuring-retake = neu
measuring-retake-help = die gewählte Messung neu nehmen (auch Leertaste)
measuring-skip = auslassen
measuring-skip-help = die aktuelle Messung auslassen
measuring-undo = zurück
measuring-undo-help = den letzten Schritt zurücknehmen (gespeicherte Messwerte bleiben im Verlauf)
measuring-units = cm/in
measuring-units-help = Längen in Zentimetern oder Zoll zeigen
measuring-estimate = berechnen
measuring-estimate-help = den Körper aus den genommenen Messwerten berechnen
measuring-new-customer-help = ein neuer Kunde (diese Sitzung bleibt offen)
measuring-sim-tape = Sim-Band
measuring-sim-tape-help = das simulierte Maßband misst die aktuelle Messung
measuring-sim-slip-help = ... auf der Zollskala abgelesen (ein Einheitenfehler)
measuring-no-session = Keine Sitzung
measuring-list-title = { $taken } von { $total } genommen
measuring-now = Jetzt: { $name }
measuring-tape-label = Band
measuring-stored-label = Wert
measuring-earlier = vorher { $values }
measuring-careful = Doppelt
measuring-flagged-what-now = Neu messen (Band halten) oder Enter, um den Wert zu behalten
measuring-checking = Der Messwert wird geprüft...
measuring-retake-hint = Neu messen: Band halten ersetzt den gespeicherten Wert
measuring-hold-hint = Haltetaste des Maßbands drücken (oder Enter)
measuring-done-title = Fertig
measuring-all-done = Jede Messung ist genommen oder ausgelassen.
measuring-done-estimate = den Körper berechnen
measuring-done-retake = die gewählte neu nehmen
measuring-flagged-others = Markiert: { $names }
measuring-skipped-count = { $n } ausgelassen
measuring-live-body = Körper bisher
measuring-live-updating = rechnet...
measuring-live-no-body = noch kein Körper
measuring-live-readings = { $n ->
    [one] { $n } Messwert
   *[other] { $n } Messwerte
  }
# Notices of the measuring screen
measuring-undo-skipped = { $name } ausgelassen
measuring-undo-retake = { $name } neu gemessen
measuring-undo-kept = markierter Wert { $name } behalten
measuring-undo-reading = Messwert { $name }
measuring-undone = Zurückgenommen: { $what } (gespeicherte Messwerte bleiben im Verlauf der Sitzung)
measuring-nothing-to-undo = Nichts zurückzunehmen
measuring-nothing-left = Nichts mehr zu messen
measuring-skipped = { $name } ausgelassen (u nimmt es zurück)
measuring-retaking = { $name } neu: nochmals messen und das Band halten
measuring-all-taken-press-e = Jede Messung ist genommen: e drücken zum Berechnen
measuring-kept-flagged = Markierten Messwert { $name } behalten
measuring-no-tape-value = Kein Wert vom Maßband: das Band herausziehen (oder seine Haltetaste drücken)
measuring-opened = Sitzung { $id } geöffnet mit { $n ->
    [one] { $n } gespeicherten Messwert
   *[other] { $n } gespeicherten Messwerten
  }
measuring-opened-unknown = Sitzung { $id } geöffnet mit { $n ->
    [one] { $n } gespeicherten Messwert
   *[other] { $n } gespeicherten Messwerten
  } ({ $unknown } nicht in ihrem Satz: { $names })
measuring-no-stored-estimate = Sitzung { $id } hat kein gespeichertes Ergebnis: e drücken, um es zu berechnen
measuring-stored-not-in-set = { $value } als { $name } gespeichert (nicht in diesem Satz)
measuring-stored = { $name } = { $value } gespeichert
measuring-stored-careful-kept = { $name } = { $value } gespeichert; behalten { $kept }, der Median dieser Runde
measuring-stored-careful-again = { $name } = { $value } gespeichert; { $status }: bitte nochmals messen
measuring-stored-retake = neu; vorher { $was }
measuring-stored-inches = Maßband zeigt Zoll
measuring-flag-far-off = { $name }: weit daneben. Neu messen oder Enter, um ihn zu behalten
measuring-flag-unit-slip = { $name }: Einheit verwechselt? Neu messen oder Enter, um ihn zu behalten
measuring-all-taken = Alle Messungen genommen: e drücken, um den Körper zu berechnen
measuring-all-taken-marked = Alle Messungen genommen ({ $skipped } ausgelassen, { $flagged } markiert): e drücken, um den Körper zu berechnen
measuring-no-readings = Noch keine Messwerte: vor dem Berechnen mindestens eine Messung nehmen
measuring-still-checking = Ein Messwert wird noch geprüft; gleich nochmals versuchen
# Careful mode's status line (ISO 20685-1: each measurement twice, a third
# when the two differ by more than the allowable error)
careful-first = Messung 1 von { $needed }
careful-next = Messung { $n } von { $needed } (bisher { $so_far })
careful-third-needed = dritte Messung nötig: die zwei weichen um { $apart } ab (erlaubt { $allowed })
careful-kept = behalten { $value } (der Median von { $readings })

## Checking a reading (the measuring screen's line after "!"; the line mode
## and `tapeshape check` keep the English sentence with the measurement's name)

check-source-people = dem, was für Menschen typisch ist
check-source-population = dem, was für die Population des Modells typisch ist
check-source-other = dem, was der andere Messwert vorhersagt
check-source-others = dem, was die anderen Messwerte vorhersagen
check-fits = { $name } { $value } { $unit } passt zu { $source } { $prediction }
check-warn-above = { $name } { $value } { $unit } liegt { $z } SD über { $source } { $prediction }: bitte prüfen
check-warn-below = { $name } { $value } { $unit } liegt { $z } SD unter { $source } { $prediction }: bitte prüfen
check-flag-above = { $name } { $value } { $unit } liegt { $z } SD über { $source } { $prediction }: neu messen
check-flag-below = { $name } { $value } { $unit } liegt { $z } SD unter { $source } { $prediction }: neu messen
check-flag-above-refused = { $name } { $value } { $unit } liegt { $z } SD über { $source } { $prediction }: neu messen (die Berechnung wird ihn ablehnen)
check-flag-below-refused = { $name } { $value } { $unit } liegt { $z } SD unter { $source } { $prediction }: neu messen (die Berechnung wird ihn ablehnen)
check-unit-slip = { $name } { $value } { $unit } passt als { $number } { $other } ({ $metres } { $unit }): Einheit am Maßband prüfen
check-not-checked = { $name } nicht geprüft: { $error }

## Estimating screen

estimating-title = Der Körper wird berechnet
stage-check = Messwerte prüfen
stage-start = erste Schätzung (Merkmalsanalyse)
stage-step1 = Formraum anpassen
stage-step2 = Oberfläche verfeinern
stage-done = fertig
estimating-refused = Die Berechnung wurde abgelehnt:
estimating-refused-back = Esc führt zurück zur Messung: die oben genannten Messwerte neu nehmen.
estimating-cancelling = Wird abgebrochen...
estimating-fitting = Der Körper wird an { $n ->
    [one] 1 Messwert
   *[other] { $n } Messwerte
  } angepasst; Esc bricht ab.
estimating-cancel = abbrechen
estimating-cancel-help = die Berechnung abbrechen (die Messwerte bleiben, wie sie sind)
estimating-back = zurück zur Messung
estimating-back-help = zurück zur Messung
estimating-cancelled = Berechnung abgebrochen; die Messwerte sind unverändert

## Result screen

result-export = exportieren
result-export-help = den Körper und report.json exportieren (die Sitzung wird als fertig markiert)
result-format = Format
result-format-help = das Format des Exports: GLB, OBJ oder PLY
result-card = Karte
result-card-help = die Karte für den Kunden: ein PDF mit dem Körper, den Messwerten und den Größen, neben den Exporten abgelegt (die Sitzung bleibt, wie sie ist)
result-back = zurück
result-back-help = zurück zur Messung (auch Esc)
result-next-customer = nächster Kunde
result-next-customer-help = der nächste Kunde (diese Sitzung wird als fertig markiert)
result-none = Noch kein Ergebnis: e auf dem Messbildschirm drücken
result-front = vorn
result-side = Seite
result-title = Ergebnis ({ $seconds } s)
result-col-measurement = Messung
result-col-target = Ziel
result-col-body = Körper
result-col-error-mm = Δ mm
result-col-error-in = Δ in
result-plausibility = Plausibilität
result-plausibility-value = Körper { $shape } (Mahalanobis { $body }), Messwerte { $readings } ({ $distance })
plausibility-typical = typisch
plausibility-unusual = ungewöhnlich
plausibility-implausible = unplausibel
result-careful = sorgfältig
result-tem = TEM { $tem } mm ({ $percent } %) über { $pairs } Messpaare
result-more-warnings = +{ $n } weitere
result-exported = exportiert { $files }
result-exported-in = in { $dir }
result-export-hint = exportiert { $format } + report.json
result-other-format = anderes Format
result-card-file = Karte { $file }
result-exporting = Wird exportiert...
result-writing-card = Die Karte wird geschrieben...
result-stored = Ergebnis gespeichert { $time }
result-stored-earlier = Ergebnis gespeichert { $time }, vor der letzten Änderung der Messwerte: b, dann e berechnet neu
result-exported-notice = { $n } Dateien nach { $dir } exportiert
result-export-failed = Export fehlgeschlagen: { $error }
result-card-written = Karte geschrieben: { $path }
result-card-failed = Die Karte wurde nicht geschrieben: { $error }; die Sitzung und ihr Ergebnis bleiben erhalten
# The Sizes box (garment names and size labels are the chart's own)
result-sizes = Größen
sizes-best = { $garment }: { $size } ({ $percent } %)
sizes-or = oder { $size }
sizes-no-size = { $garment }: keine Größe ({ $missing } unbekannt)
sizes-none = keine Größen: { $error }
sizes-none-report = keine Größen: das gespeicherte Ergebnis ist nicht lesbar ({ $error })
sizes-tight = { $place } zu eng
sizes-loose = { $place } zu weit
sizes-too-short = { $place } zu kurz
sizes-too-long = { $place } zu lang
sizes-narrow = { $place } zu schmal
sizes-wide = { $place } zu breit

## History screen

history-title = Sitzungen ({ $n })
history-title-loading = Sitzungen (wird geladen...)
history-col-id = ID
history-col-customer = Kunde
history-col-set = Satz
history-col-status = Status
history-col-readings = MW
history-col-updated = geändert (UTC)
history-empty = Noch keine Sitzungen gespeichert
status-open = offen
status-done = fertig
status-abandoned = verworfen
history-confirm-delete = löschen
history-confirm-delete-help = endgültig löschen
history-keep = behalten
history-keep-help = behalten
history-keep-it = behalten
history-move-help = eine Sitzung der Liste wählen (auch k / j)
history-reopen = öffnen
history-reopen-help = die Sitzung zum Messen wieder öffnen (auch o)
history-result = Ergebnis
history-result-help = ihr gespeichertes Ergebnis zeigen (nichts wird neu berechnet)
history-estimate = berechnen
history-estimate-help = die Sitzung neu berechnen
history-export = exportieren
history-export-help = exportieren (ihr gespeichertes Ergebnis, wenn es zu ihren Messwerten gehört)
history-delete = löschen
history-delete-help = die Sitzung löschen (fragt vorher; auch D)
history-back = zurück
history-back-help = zurück zum vorigen Bildschirm (auch b)
history-reload-help = die Liste neu laden
history-deleted = Sitzung { $id } gelöscht
history-kept = Sitzung behalten
history-delete-title = Löschen?
history-delete-question = Sitzung { $id } endgültig löschen? ({ $customer }, { $readings ->
    [one] 1 Messwert
   *[other] { $readings } Messwerte
  }, { $retaken } neu)

## The runner (what failed, and what to do)

run-keyboard-failed = Tastatur nicht lesbar: { $error }; die Station neu starten
run-open-failed = Sitzung { $id } lässt sich nicht öffnen: { $error }
run-capture-failed = der übernommene Wert lässt sich nicht speichern: { $error }
run-no-stored-estimate = Sitzung { $session } hat kein gespeichertes Ergebnis: e drücken, um es zu berechnen
run-withdraw-failed = Messwert { $id } lässt sich nicht zurücknehmen: { $error }
run-mark-failed = die Markierung von { $name } lässt sich nicht speichern: { $error }
run-status-failed = Sitzung { $id } lässt sich nicht als { $status } markieren: { $error }
run-list-failed = die Sitzungen lassen sich nicht lesen: { $error }
run-delete-failed = Sitzung { $id } lässt sich nicht löschen: { $error }
run-no-sim-tape = außerhalb der Demo gibt es kein simuliertes Maßband
run-terminal-failed = das Terminal lässt sich nicht einrichten
run-keyboard-thread-failed = der Tastatur-Thread lässt sich nicht starten
run-log-open-failed = die Protokolldatei { $path } lässt sich nicht öffnen
run-log-written = Protokollmeldungen dieses Laufs: { $path }
run-internal-error = die Oberfläche stoppte bei einem internen Fehler (Details in { $path }); jeder Messwert ist gespeichert: neu starten und die Sitzung fortsetzen

## The demo's simulated tape

sim-no-value = der simulierte Kunde hat keinen Wert für { $name }; mit Enter übernehmen
sim-stopped = das simulierte Maßband hat aufgehört; die Demo neu starten

## Die Warnungen der Schätzung (Ergebnisbildschirm, predict, session show).

warn-no-unit = keine Einheit angegeben für { $names }: gelesen als { $unit }
warn-unit-mm = Millimeter
warn-unit-cm = Zentimeter
warn-unit-m = Meter
warn-unit-in = Zoll
warn-kept = vom Bediener beibehalten: { $what }
warn-check-reading = { $what }: bitte diesen Messwert prüfen
warn-out-of-range-above = { $name } { $typed } ({ $cm } cm) liegt { $z } SD über der Population, die das Modell kennt (typisch: { $typical }): Messwert und Einheit prüfen
warn-out-of-range-below = { $name } { $typed } ({ $cm } cm) liegt { $z } SD unter der Population, die das Modell kennt (typisch: { $typical }): Messwert und Einheit prüfen
warn-unit-slip = { $name } { $typed } sieht nach { $unit } aus: { $number }{ $symbol } eingeben (typisch: { $typical })
warn-unit-slip-bare = { $name } { $typed } sieht nach { $unit } aus: { $number }{ $symbol } eingeben (typisch: { $typical }); eine Zahl ohne Einheit wird als { $bare } gelesen
warn-others-more = { $list } und { $n } weitere
warn-against-one-above = { $name } { $cm } cm liegt { $z } SD über dem, was { $others } vorhersagt ({ $mu } ± { $sd } cm)
warn-against-others-above = { $name } { $cm } cm liegt { $z } SD über dem, was { $others } vorhersagen ({ $mu } ± { $sd } cm)
warn-against-one-below = { $name } { $cm } cm liegt { $z } SD unter dem, was { $others } vorhersagt ({ $mu } ± { $sd } cm)
warn-against-others-below = { $name } { $cm } cm liegt { $z } SD unter dem, was { $others } vorhersagen ({ $mu } ± { $sd } cm)
warn-unusual-set = ungewöhnliche Kombination von Maßen (Mahalanobis-Abstand { $distance } über { $n } Messwerte, { $percent } % der Population liegen näher am Mittel): das Ergebnis ist plausibel, aber bitte die Messwerte prüfen
warn-estimated-with-kept = geschätzt mit ungewöhnlichen Messwerten, die der Bediener beibehalten hat ({ $names }): der Körper trifft sie, soweit eine menschlich aussehende Oberfläche es zulässt; Plausibilität der Maße: { $percent } % der Trainingspopulation liegen näher am Mittel (Mahalanobis-Abstand { $distance })
warn-recorded-not-fitted = { $n ->
    [one] { $n } Messwert erfasst, nicht angepasst: { $names }: das stehende Körpermodell kann dieses Maß nicht so nehmen, wie ANSUR II es definiert (gebeugte Umfänge, Tasterzirkel, der das Gewebe zusammendrückt), daher folgt der Körper ihm nicht; der Messwert steht im Bericht neben dem Wert des Körpers
   *[other] { $n } Messwerte erfasst, nicht angepasst: { $names }: das stehende Körpermodell kann diese Maße nicht so nehmen, wie ANSUR II sie definiert (gebeugte Umfänge, Tasterzirkel, der das Gewebe zusammendrückt), daher folgt der Körper ihnen nicht; die Messwerte stehen im Bericht neben den Werten des Körpers
}
warn-recorded-sum-of-parts = { $name } erfasst, nicht angepasst: am Körper ist es die Summe aus { $parts }, die angepasst werden; ANSUR II nimmt es mit einem anderen Instrument und in anderer Haltung (im Mittel etwa 10 mm kürzer als diese Summe), alle zusammen anzupassen verlangte vom Körper einen Widerspruch; der Messwert steht im Bericht neben dem Wert des Körpers
warn-stage-step1 = Schritt 1
warn-stage-step2 = Schritt 2
warn-solver-stopped = { $stage }, Runde { $round }: Optimierer angehalten: { $reason }
warn-zero-length = { $stage }: Maß „{ $name }“ hat auf der aktuellen Form die Länge null und blieb in dieser Runde außen vor
warn-objective-map = MAP-Zielfunktion
warn-objective-energy = Messenergie E_m (mm^4)
warn-step1-kept-start = Schritt 1 endete mit höherer { $objective } als der Start ({ $end } statt { $start }): Startform beibehalten
warn-step2-kept-round = Schritt 2 endete mit höherer Messenergie als Schritt 1 (E_m { $end } statt { $step1 } mm^4): Form vom Beginn der Runde { $round } beibehalten (E_m { $kept })
warn-step2-kept-step1 = Schritt 2 endete mit höherer Messenergie als Schritt 1 (E_m { $end } statt { $step1 } mm^4): Form aus Schritt 1 beibehalten
warn-triangles = Schritt 2 hat { $flipped } Dreiecke umgeklappt und { $collapsed } zusammengedrückt: die Maße passen womöglich nicht zusammen
warn-step1-smoothed = Die Anpassung im Formraum hat { $folded } Dreiecke der Oberfläche gefaltet: vor der Verfeinerung geglättet, { $left } übrig
warn-folds-smoothed = Schritt 2 hat { $folded } Dreiecke der Oberfläche gefaltet: geglättet, { $left } übrig
warn-surface-over-readings = { $folded } Dreiecke der Oberfläche blieben gefaltet, wo der Körper die Maße traf: geglättet, { $left } übrig; diese Maße liegen jetzt außerhalb ihres zulässigen Fehlers: { $names }
warn-surface-over-readings-none = { $folded } Dreiecke der Oberfläche blieben gefaltet, wo der Körper die Maße traf: geglättet, { $left } übrig; kein Maß hat seinen zulässigen Fehler verlassen
warn-soft-pull-reduced = Den Statistiken realer Menschen für die nicht gemessenen Maße zu { $asked } % zu folgen, hat die Oberfläche gefaltet oder geknickt: ihnen zu { $pull } % gefolgt
warn-far-from-population = die Maße liegen weit von der Trainingspopulation entfernt (Mahalanobis-Abstand { $distance } über { $n } Maße): die Form wird auf { $sd } SD gehalten und trifft womöglich nicht alle
warn-not-fitted = „{ $name }“ ließ sich nicht auf { $limit } mm genau anpassen (Fehler { $error } mm)
warn-measuring-failed = die nicht angegebenen Maße ließen sich nicht messen: { $reason }
refuse-kept-beyond = { $what }; vom Bediener beibehalten, aber außerhalb dessen, was ein Mensch misst
refuse-contradiction = die Messwerte widersprechen einander: { $list }; diese Messwerte neu nehmen oder, wenn sie stimmen, beibehalten (die Schätzung trifft sie dann, soweit ein menschlich aussehender Körper es zulässt)
