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

/// The form's word for a sex (shown, and stored in the session notes).
pub fn sex_word(sex: Option<Sex>) -> &'static str {
    match sex {
        None => "not given",
        Some(Sex::Female) => "female",
        Some(Sex::Male) => "male",
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
    /// New sessions take each measurement twice (careful mode,
    /// `tapeshape station --careful`).
    pub careful: bool,
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
        }
    }

    /// The form for the next customer (a new id, the same set).
    pub fn next_customer(&self) -> Self {
        let n = self.customers_started + 1;
        Self {
            customer: customer_id(self.id_seed, n),
            customers_started: n,
            resume: None,
            careful: self.careful,
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
    DeleteChar,
    Start,
}

fn bindings(app: &App) -> Vec<Binding<Action>> {
    if app.form.resume.is_some() {
        return vec![
            Binding::new(
                &[ch('y'), ch('r'), code(KeyCode::Enter)],
                "y",
                "resume",
                "resume",
                Action::Resume,
            ),
            Binding::new(
                &[ch('n')],
                "n",
                "new customer",
                "start a new customer",
                Action::Decline,
            ),
            Binding::help_only(
                &[code(KeyCode::Esc)],
                "Esc",
                "close the offer (the session stays open; find it under h)",
                Action::CloseOffer,
            ),
        ];
    }
    let mut b = vec![
        Binding::new(
            &[code(KeyCode::Tab), code(KeyCode::Down)],
            "Tab",
            "field",
            "next field (also down)",
            Action::NextField,
        ),
        Binding::help_only(
            &[code(KeyCode::BackTab), code(KeyCode::Up)],
            "S-Tab",
            "previous field (also up)",
            Action::PreviousField,
        ),
        Binding::new(
            &[code(KeyCode::Left), code(KeyCode::Right)],
            "<-/->",
            "choose",
            "choose the sex, the measurement set or the data choice",
            Action::Choose,
        ),
        Binding::new(
            &[code(KeyCode::Enter)],
            "Enter",
            "start",
            "start the session; readings are stored as they are taken",
            Action::Start,
        ),
    ];
    match app.form.field {
        FormField::Sex => {
            b.push(Binding::help_only(
                &[ch('f'), ch('F')],
                "f",
                "female",
                Action::Female,
            ));
            b.push(Binding::help_only(
                &[ch('m'), ch('M')],
                "m",
                "male",
                Action::Male,
            ));
        }
        FormField::Customer | FormField::Age | FormField::File => b.push(Binding::help_only(
            &[code(KeyCode::Backspace)],
            "Backspace",
            "delete the last character typed",
            Action::DeleteChar,
        )),
        FormField::Consent => {
            b.push(Binding::help_only(
                &[ch('k'), ch('K')],
                "k",
                "keep my data (the chain keeps the sessions until the customer asks to erase them)",
                Action::Keep,
            ));
            b.push(Binding::help_only(
                &[ch('v'), ch('V')],
                "v",
                "this visit only (purged after the hub's retention period)",
                Action::Visit,
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
                    format!(
                        "Session {} stays open; find it under h (history)",
                        offer.session
                    ),
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
                _ => {}
            }
        }
        Action::Female => form.sex = Some(Sex::Female),
        Action::Male => form.sex = Some(Sex::Male),
        Action::Keep => form.consent = Consent::Keep,
        Action::Visit => form.consent = Consent::Visit,
        Action::DeleteChar => {
            match form.field {
                FormField::Customer => form.customer.pop(),
                FormField::Age => form.age.pop(),
                FormField::File => form.file.pop(),
                FormField::Sex | FormField::Set | FormField::Consent => None,
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
        form.error = Some("Give a customer id (any text; a new one is suggested)".into());
        form.field = FormField::Customer;
        return;
    }
    let age = if form.age.is_empty() {
        None
    } else {
        match form.age.parse::<u32>() {
            Ok(a) if (16..=110).contains(&a) => Some(a),
            _ => {
                form.error = Some(format!(
                    "Age {} is not between 16 and 110: correct it or leave it empty",
                    form.age
                ));
                form.field = FormField::Age;
                return;
            }
        }
    };
    let set = form.set();
    if set.is_empty() {
        form.error = Some("Give the path of the measurement set file (TOML)".into());
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
    let field = |name: FormField, label: &str, value: String, help: &str| -> Line<'static> {
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
        None => "< custom file >".to_string(),
    };
    let mut lines = vec![
        Line::raw(""),
        field(
            FormField::Customer,
            "customer id",
            format!("{} ", f.customer),
            "opaque; no name needed",
        ),
        field(
            FormField::Sex,
            "sex",
            format!("< {} >", sex_word(f.sex)),
            "f / m",
        ),
        field(
            FormField::Age,
            "age (optional)",
            format!("{:<3}", f.age),
            "years",
        ),
        field(FormField::Set, "measurements", set_value, "<- -> to choose"),
    ];
    if f.set_choice == BUILTIN_SET_CHOICES.len() {
        lines.push(field(
            FormField::File,
            "set file",
            format!("{} ", f.file),
            "TOML file",
        ));
    }
    lines.push(field(
        FormField::Consent,
        "their data",
        format!("< {} >", f.consent.label()),
        "ask them: k keep / v visit",
    ));
    lines.push(Line::raw(""));
    let blurb = match BUILTIN_SET_CHOICES.get(f.set_choice) {
        Some(name) => set_blurb(name),
        None => "a measurement set file (TOML, as host/measure/sets/*.toml)".to_string(),
    };
    lines.push(Line::styled(format!("  {blurb}"), st(m, Role::Dim)));
    if let Some(e) = &f.error {
        lines.push(Line::raw(""));
        lines.push(Line::styled(format!("  {e}"), st(m, Role::Bad)));
    }
    lines.push(Line::raw(""));
    lines.push(Line::styled(
        "  Enter starts the session; readings are stored as they are taken.",
        st(m, Role::Dim),
    ));
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(Block::bordered().title(" New customer ")),
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
                    " Session {} (customer {}, {}) is not finished:",
                    r.session,
                    r.customer,
                    r.set.as_deref().unwrap_or("no set")
                ),
                st(m, Role::Big),
            )]),
            Line::raw(format!(
                " {} readings are stored. Resume it with them?",
                r.readings
            )),
            Line::raw(""),
            hint_line(m, &keys),
        ];
        frame.render_widget(
            Paragraph::new(text).block(
                Block::bordered()
                    .title(" Resume? ")
                    .border_style(st(m, Role::Warn)),
            ),
            popup,
        );
    }
}

/// "name: N measurements; description" of a built-in set, parsed once.
fn set_blurb(name: &str) -> String {
    static BLURBS: std::sync::OnceLock<Vec<(String, String)>> = std::sync::OnceLock::new();
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
                (
                    s.name.clone(),
                    format!("{}: {} measurements. {first}", s.name, s.definitions.len()),
                )
            })
            .collect()
    });
    all.iter()
        .find(|(n, _)| n == name)
        .map(|(_, b)| b.clone())
        .unwrap_or_else(|| name.to_string())
}
