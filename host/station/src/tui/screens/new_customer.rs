//! The new customer screen: a generated opaque customer id, sex, optional
//! age, the measurement set (quick, ansur, paper34 or a set file) and the
//! customer's choice about their data (keep my data / this visit only); an
//! unfinished session is offered for resuming first.
//!
//! The data choice starts at "this visit only" (privacy by default): the
//! chain keeps a customer's sessions past the hub's retention only when the
//! operator has asked and the customer said "keep my data". The choice is
//! stored with the session and sent with its events.

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Clear, Paragraph, Wrap};
use ratatui::Frame;
use tapeshape_population::ansur::Sex;

use crate::i18n::{self, msg, tr};
use crate::session::ResumeOffer;
use crate::store::Consent;
use crate::tui::app::{action, AfterOpen, App, Effect, Global, Level};
use crate::tui::keys::{ch, code, hints as hints_of, Binding, Hint};
use crate::tui::theme::{centered, hint, hint_line, st, Role};

/// Measurement sets offered for a new customer (besides a custom file).
pub const BUILTIN_SET_CHOICES: [&str; 3] = ["quick", "ansur", "paper34"];

/// The sexes the form offers, in the order `<-`/`->` cycle through them
/// (`None`: not given).
const SEXES: [Option<Sex>; 3] = [None, Some(Sex::Female), Some(Sex::Male)];

/// The data choices the form offers, in the order `<-`/`->` cycle through
/// them (the first is the default).
const CONSENTS: [Consent; 2] = [Consent::Visit, Consent::Keep];

/// The word for a sex stored in the session notes (`sex: female`; English
/// in every language, [`sex_of_notes`] reads it back). The form shows
/// [`sex_text`].
pub fn sex_word(sex: Option<Sex>) -> &'static str {
    match sex {
        None => "not given",
        Some(Sex::Female) => "female",
        Some(Sex::Male) => "male",
    }
}

/// The form's word for a sex, in the chosen language.
pub fn sex_text(sex: Option<Sex>) -> String {
    match sex {
        None => tr!("sex-none"),
        Some(Sex::Female) => tr!("sex-female"),
        Some(Sex::Male) => tr!("sex-male"),
    }
}

/// The form's words for the customer's data choice, in the chosen language
/// (the store's `Consent::label` is English, for the commands).
pub fn consent_text(consent: Consent) -> String {
    match consent {
        Consent::Keep => tr!("consent-keep"),
        Consent::Visit => tr!("consent-visit"),
    }
}

/// The form's words for how often each measurement is taken.
pub fn readings_text(careful: bool) -> String {
    if careful {
        tr!("readings-twice")
    } else {
        tr!("readings-once")
    }
}

/// The sex stored in a session's notes by this form (`sex: female, age:
/// 34`), for the estimate; `None` when not given or not written by it.
pub fn sex_of_notes(notes: Option<&str>) -> Option<Sex> {
    let rest = notes?
        .split(',')
        .find_map(|p| p.trim().strip_prefix("sex:"))?;
    Sex::parse(rest)
}

/// Fields of the new customer form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormField {
    /// Customer id (generated, editable).
    Customer,
    /// Sex.
    Sex,
    /// Age in years (optional).
    Age,
    /// Measurement set.
    Set,
    /// Path of a custom set file.
    File,
    /// Each measurement once, or twice (careful mode).
    Readings,
    /// The customer's choice about their data.
    Consent,
}

/// The new customer screen's state: the form and the resume offer.
#[derive(Clone, Debug, PartialEq)]
pub struct CustomerForm {
    /// Opaque customer id.
    pub customer: String,
    /// Sex (`None`: not given).
    pub sex: Option<Sex>,
    /// Age digits as typed.
    pub age: String,
    /// Index into [`BUILTIN_SET_CHOICES`], or its length for a custom file.
    pub set_choice: usize,
    /// Custom set file path as typed.
    pub file: String,
    /// The customer's choice about their data ("this visit only" until
    /// they choose to keep it).
    pub consent: Consent,
    /// Focused field.
    pub field: FormField,
    /// What is wrong with the form, if the last Enter was refused.
    pub error: Option<String>,
    /// Unfinished session offered for resuming.
    pub resume: Option<ResumeOffer>,
    /// Customer ids handed out so far (makes the next one differ).
    pub customers_started: u64,
    /// Seed of the generated customer ids.
    pub id_seed: u64,
    /// This customer's session takes each measurement twice (careful mode),
    /// chosen on the form.
    pub careful: bool,
    /// What the form offers each new customer (`tapeshape station
    /// --careful`): a careful customer does not make the next one careful.
    pub careful_default: bool,
}

impl CustomerForm {
    /// A fresh form with a generated customer id and `set` preselected.
    pub fn new(id_seed: u64, set: &str) -> Self {
        let set_choice = BUILTIN_SET_CHOICES
            .iter()
            .position(|s| *s == set)
            .unwrap_or(BUILTIN_SET_CHOICES.len());
        let file = if set_choice == BUILTIN_SET_CHOICES.len() {
            set.to_string()
        } else {
            String::new()
        };
        Self {
            customer: customer_id(id_seed, 0),
            sex: None,
            age: String::new(),
            set_choice,
            file,
            consent: CONSENTS[0],
            field: FormField::Sex,
            error: None,
            resume: None,
            customers_started: 0,
            id_seed,
            careful: false,
            careful_default: false,
        }
    }

    /// The form with `careful` as the station's choice for new customers.
    pub fn with_careful_default(self, careful: bool) -> Self {
        Self {
            careful,
            careful_default: careful,
            ..self
        }
    }

    /// The form for the next customer (a new id, the same set).
    pub fn next_customer(&self) -> Self {
        let n = self.customers_started + 1;
        Self {
            customer: customer_id(self.id_seed, n),
            customers_started: n,
            resume: None,
            careful: self.careful_default,
            careful_default: self.careful_default,
            ..Self::new(self.id_seed, &self.set())
        }
    }

    /// The set the form names (built-in name or file path).
    pub fn set(&self) -> String {
        BUILTIN_SET_CHOICES
            .get(self.set_choice)
            .map(|s| s.to_string())
            .unwrap_or_else(|| self.file.trim().to_string())
    }

    fn fields(&self) -> Vec<FormField> {
        let mut f = vec![
            FormField::Customer,
            FormField::Sex,
            FormField::Age,
            FormField::Set,
        ];
        if self.set_choice == BUILTIN_SET_CHOICES.len() {
            f.push(FormField::File);
        }
        f.push(FormField::Readings);
        f.push(FormField::Consent);
        f
    }

    /// Is a text field focused (keys are typed into it)?
    pub fn typing(&self) -> bool {
        self.resume.is_none()
            && matches!(
                self.field,
                FormField::Customer | FormField::File | FormField::Age
            )
    }
}

/// An opaque customer id from a seed and a counter (`c-` and 6 base-32
/// characters): no name, nothing personal, differs per customer.
pub fn customer_id(seed: u64, n: u64) -> String {
    // splitmix64: a tiny, well-known mixer; a crate would be overkill for
    // six characters of an id.
    let mut z = seed.wrapping_add(n.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    const ALPHABET: &[u8; 32] = b"0123456789abcdefghjkmnpqrstvwxyz";
    let s: String = (0..6)
        .map(|k| ALPHABET[((z >> (5 * k)) & 31) as usize] as char)
        .collect();
    format!("c-{s}")
}

/// What the screen's keys do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    Resume,
    Decline,
    CloseOffer,
    NextField,
    PreviousField,
    Choose,
    Female,
    Male,
    Keep,
    Visit,
    Once,
    Twice,
    DeleteChar,
    Start,
}

fn bindings(app: &App) -> Vec<Binding<Action>> {
    if app.form.resume.is_some() {
        return vec![
            // `j` (German "ja") resumes too: harmless, and what a German
            // operator presses.
            Binding::new(
                &[ch('y'), ch('j'), ch('r'), code(KeyCode::Enter)],
                msg!("resume-key"),
                msg!("resume-resume"),
                msg!("resume-resume-help"),
                Action::Resume,
            ),
            Binding::new(
                &[ch('n')],
                "n",
                msg!("resume-new"),
                msg!("resume-new-help"),
                Action::Decline,
            ),
            Binding::help_only(
                &[code(KeyCode::Esc)],
                msg!("key-esc"),
                msg!("resume-close-help"),
                Action::CloseOffer,
            ),
        ];
    }
    let mut b = vec![
        Binding::new(
            &[code(KeyCode::Tab), code(KeyCode::Down)],
            msg!("key-tab"),
            msg!("form-next-field"),
            msg!("form-next-field-help"),
            Action::NextField,
        ),
        Binding::help_only(
            &[code(KeyCode::BackTab), code(KeyCode::Up)],
            msg!("key-shift-tab"),
            msg!("form-previous-field-help"),
            Action::PreviousField,
        ),
        Binding::new(
            &[code(KeyCode::Left), code(KeyCode::Right)],
            msg!("key-left-right"),
            msg!("form-choose"),
            msg!("form-choose-help"),
            Action::Choose,
        ),
        Binding::new(
            &[code(KeyCode::Enter)],
            msg!("key-enter"),
            msg!("form-start"),
            msg!("form-start-help"),
            Action::Start,
        ),
    ];
    match app.form.field {
        FormField::Sex => {
            // `w` (German "weiblich") is female too.
            b.push(Binding::help_only(
                &[ch('f'), ch('F'), ch('w'), ch('W')],
                msg!("form-female-key"),
                msg!("form-female-help"),
                Action::Female,
            ));
            b.push(Binding::help_only(
                &[ch('m'), ch('M')],
                "m",
                msg!("form-male-help"),
                Action::Male,
            ));
        }
        FormField::Customer | FormField::Age | FormField::File => b.push(Binding::help_only(
            &[code(KeyCode::Backspace)],
            msg!("key-backspace"),
            msg!("form-delete-char-help"),
            Action::DeleteChar,
        )),
        FormField::Consent => {
            b.push(Binding::help_only(
                &[ch('k'), ch('K')],
                "k",
                msg!("form-keep-help"),
                Action::Keep,
            ));
            b.push(Binding::help_only(
                &[ch('v'), ch('V')],
                "v",
                msg!("form-visit-help"),
                Action::Visit,
            ));
        }
        FormField::Readings => {
            b.push(Binding::help_only(
                &[ch('1')],
                "1",
                msg!("form-once-help"),
                Action::Once,
            ));
            b.push(Binding::help_only(
                &[ch('2')],
                "2",
                msg!("form-twice-help"),
                Action::Twice,
            ));
        }
        FormField::Set => {}
    }
    b
}

/// The keys that work anywhere that the footer shows here.
pub fn footer_globals(app: &App) -> &'static [Global] {
    if app.form.resume.is_some() {
        &[Global::Quit]
    } else {
        &[Global::History, Global::Device, Global::Help]
    }
}

/// The screen's keys, with their words.
pub fn hints(app: &App) -> Vec<Hint> {
    hints_of(&bindings(app))
}

/// A key on the new customer screen.
pub fn on_key(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    let Some(a) = action(&bindings(app), &key) else {
        if app.form.resume.is_none() {
            type_char(&mut app.form, key);
        }
        return;
    };
    let form = &mut app.form;
    let fields = form.fields();
    let pos = fields.iter().position(|f| *f == form.field).unwrap_or(0);
    match a {
        Action::Resume => {
            if let Some(offer) = form.resume.take() {
                app.after_open = Some(AfterOpen::Measure);
                fx.push(Effect::OpenSession(offer.session));
            }
        }
        Action::Decline => {
            if let Some(offer) = form.resume.take() {
                app.note(
                    Level::Info,
                    tr!("resume-declined", session = offer.session.to_string()),
                );
            }
        }
        Action::CloseOffer => form.resume = None,
        Action::NextField => form.field = fields[(pos + 1) % fields.len()],
        Action::PreviousField => form.field = fields[(pos + fields.len() - 1) % fields.len()],
        Action::Choose => {
            let forward = key.code == KeyCode::Right;
            let step = |i: usize, n: usize| {
                if forward {
                    (i + 1) % n
                } else {
                    (i + n - 1) % n
                }
            };
            match form.field {
                FormField::Sex => {
                    let i = SEXES.iter().position(|s| *s == form.sex).unwrap_or(0);
                    form.sex = SEXES[step(i, SEXES.len())];
                }
                FormField::Set => {
                    form.set_choice = step(form.set_choice, BUILTIN_SET_CHOICES.len() + 1)
                }
                FormField::Consent => {
                    let i = CONSENTS
                        .iter()
                        .position(|c| *c == form.consent)
                        .unwrap_or(0);
                    form.consent = CONSENTS[step(i, CONSENTS.len())];
                }
                FormField::Readings => form.careful = !form.careful,
                _ => {}
            }
        }
        Action::Female => form.sex = Some(Sex::Female),
        Action::Male => form.sex = Some(Sex::Male),
        Action::Keep => form.consent = Consent::Keep,
        Action::Visit => form.consent = Consent::Visit,
        Action::Once => form.careful = false,
        Action::Twice => form.careful = true,
        Action::DeleteChar => {
            match form.field {
                FormField::Customer => form.customer.pop(),
                FormField::Age => form.age.pop(),
                FormField::File => form.file.pop(),
                FormField::Sex | FormField::Set | FormField::Readings | FormField::Consent => None,
            };
        }
        Action::Start => submit(app, fx),
    }
}

/// A character typed into the focused text field (within its limits).
fn type_char(form: &mut CustomerForm, key: KeyEvent) {
    let KeyCode::Char(c) = key.code else { return };
    if key.modifiers.contains(KeyModifiers::CONTROL) || c.is_control() {
        return;
    }
    match form.field {
        FormField::Customer if form.customer.len() < 64 => form.customer.push(c),
        FormField::Age if c.is_ascii_digit() && form.age.len() < 3 => form.age.push(c),
        FormField::File if form.file.len() < 512 => form.file.push(c),
        _ => {}
    }
}

fn submit(app: &mut App, fx: &mut Vec<Effect>) {
    let form = &mut app.form;
    let customer = form.customer.trim().to_string();
    if customer.is_empty() {
        form.error = Some(tr!("form-error-customer"));
        form.field = FormField::Customer;
        return;
    }
    let age = if form.age.is_empty() {
        None
    } else {
        match form.age.parse::<u32>() {
            Ok(a) if (16..=110).contains(&a) => Some(a),
            _ => {
                form.error = Some(tr!("form-error-age", age = form.age.as_str()));
                form.field = FormField::Age;
                return;
            }
        }
    };
    let set = form.set();
    if set.is_empty() {
        form.error = Some(tr!("form-error-file"));
        form.field = FormField::File;
        return;
    }
    form.error = None;
    let mut notes = format!("sex: {}", sex_word(form.sex));
    if let Some(a) = age {
        notes.push_str(&format!(", age: {a}"));
    }
    app.after_open = Some(AfterOpen::Measure);
    fx.push(Effect::CreateSession {
        customer,
        set,
        notes: Some(notes),
        consent: form.consent,
        careful: form.careful,
    });
}

/// Draws the form (and the resume offer over it) into `area`.
pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let f = &app.form;
    let field = |name: FormField, label: String, value: String, help: String| -> Line<'static> {
        let focus = f.field == name && f.resume.is_none();
        let marker = if focus { "> " } else { "  " };
        Line::from(vec![
            Span::raw(marker.to_string()),
            Span::styled(format!("{label:<16}"), st(m, Role::Dim)),
            Span::styled(
                value,
                if focus {
                    st(m, Role::Focus)
                } else {
                    st(m, Role::Big)
                },
            ),
            Span::styled(format!("  {help}"), st(m, Role::Dim)),
        ])
    };
    let set_value = match BUILTIN_SET_CHOICES.get(f.set_choice) {
        Some(s) => format!("< {s} >"),
        None => format!("< {} >", tr!("form-custom-file")),
    };
    let mut lines = vec![
        Line::raw(""),
        field(
            FormField::Customer,
            tr!("form-customer"),
            format!("{} ", f.customer),
            tr!("form-customer-help"),
        ),
        field(
            FormField::Sex,
            tr!("form-sex"),
            format!("< {} >", sex_text(f.sex)),
            tr!("form-sex-help"),
        ),
        field(
            FormField::Age,
            tr!("form-age"),
            format!("{:<3}", f.age),
            tr!("form-age-help"),
        ),
        field(
            FormField::Set,
            tr!("form-set"),
            set_value,
            tr!("form-set-help"),
        ),
    ];
    if f.set_choice == BUILTIN_SET_CHOICES.len() {
        lines.push(field(
            FormField::File,
            tr!("form-file"),
            format!("{} ", f.file),
            tr!("form-file-help"),
        ));
    }
    lines.push(field(
        FormField::Readings,
        tr!("form-readings"),
        format!("< {} >", readings_text(f.careful)),
        tr!("form-readings-help"),
    ));
    lines.push(field(
        FormField::Consent,
        tr!("form-consent"),
        format!("< {} >", consent_text(f.consent)),
        tr!("form-consent-help"),
    ));
    lines.push(Line::raw(""));
    let blurb = match BUILTIN_SET_CHOICES.get(f.set_choice) {
        Some(name) => set_blurb(name),
        None => tr!("form-file-blurb"),
    };
    lines.push(Line::styled(format!("  {blurb}"), st(m, Role::Dim)));
    if let Some(e) = &f.error {
        lines.push(Line::raw(""));
        lines.push(Line::styled(format!("  {e}"), st(m, Role::Bad)));
    }
    lines.push(Line::raw(""));
    lines.push(Line::styled(
        format!("  {}", tr!("form-enter-starts")),
        st(m, Role::Dim),
    ));
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(Block::bordered().title(format!(" {} ", tr!("new-customer-title")))),
        area,
    );
    if let Some(r) = &f.resume {
        let popup = centered(area, 64, 8);
        frame.render_widget(Clear, popup);
        // The offer's keys in its own words (the help's), from the bindings.
        let keys: Vec<Hint> = bindings(app)
            .iter()
            .filter(|b| b.footer.is_some())
            .map(|b| hint(b.shown, b.help))
            .collect();
        let text = vec![
            Line::raw(""),
            Line::from(vec![Span::styled(
                format!(
                    " {}",
                    tr!(
                        "resume-not-finished",
                        session = r.session.to_string(),
                        customer = r.customer.as_str(),
                        set = r.set.clone().unwrap_or_else(|| tr!("resume-no-set"))
                    )
                ),
                st(m, Role::Big),
            )]),
            Line::raw(format!(" {}", tr!("resume-readings", n = r.readings))),
            Line::raw(""),
            hint_line(m, &keys),
        ];
        frame.render_widget(
            Paragraph::new(text).block(
                Block::bordered()
                    .title(format!(" {} ", tr!("resume-title")))
                    .border_style(st(m, Role::Warn)),
            ),
            popup,
        );
    }
}

/// "name: N measurements. description" of a built-in set in the chosen
/// language: the catalogue's `set-description-<name>`, else the first
/// sentence of the set's own description (sets parsed once).
fn set_blurb(name: &str) -> String {
    /// Per built-in set: name, number of measurements, first sentence.
    type Blurb = (String, usize, String);
    static BLURBS: std::sync::OnceLock<Vec<Blurb>> = std::sync::OnceLock::new();
    let all = BLURBS.get_or_init(|| {
        BUILTIN_SET_CHOICES
            .iter()
            .filter_map(|n| tapeshape_measure::MeasurementSet::builtin(n).ok())
            .map(|s| {
                let first = s
                    .description
                    .split(". ")
                    .next()
                    .unwrap_or("")
                    .trim()
                    .to_string();
                (s.name.clone(), s.definitions.len(), first)
            })
            .collect()
    });
    all.iter()
        .find(|(n, _, _)| n == name)
        .map(|(n, count, first)| {
            tr!(
                "set-blurb",
                name = n.as_str(),
                count = *count,
                description = i18n::text_or(&format!("set-description-{n}"), first)
            )
        })
        .unwrap_or_else(|| name.to_string())
}
