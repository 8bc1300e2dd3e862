"""Every name the firmware's modules intern, for session_modules.py's intern_names: importing this
interns them at once, first thing at boot. Generated: python -m desktop.firmware.names >
device/firmware_names.py (tests/test_firmware_files.py fails when it is stale). MODULES: the
firmware's modules, whose file names intern_names interns as a board names them.
"""


def _(_):
    _.ADS1292Pair; _.AUTO; _.Acquisition; _.AdcSupervisor; _.App; _.BADSYNC; _.BAD_ARGUMENT; _.BAD_ENCODING;
    _.BAD_JSON; _.BAD_REQUEST; _.BAD_SCALE; _.BAD_VALUE; _.BATCHES; _.BINOM; _.BLOCKS; _.BUSY; _.BUTTON; _.Board;
    _.Button; _.CALIBRATING; _.CANCELLED; _.CHECK_MS; _.CHI2_001; _.CHUNK; _.CLIPPED; _.CLIP_CODES;
    _.CLIP_FRACTION; _.COLLECTING; _.COND_LIMIT; _.COUNT; _.Calibration; _.CalibrationFlow; _.Coverage;
    _.DATA_BAUD; _.DATA_LINE; _.DEGENERATE_COVERAGE; _.DEGREE; _.DELAY; _.DISCARDED; _.DONE; _.DONE_QUICK; _.Delag;
    _.DigitalInOut; _.Drain; _.EDGE_MS; _.ENOUGH; _.EV_BOOT; _.EV_CAL; _.EV_DATA; _.EV_EMULATOR_BUSY; _.EV_ERROR;
    _.EV_FAULT; _.EV_RAW; _.EV_SAFE_MODE; _.EXPECTED_IDS; _.EllipsoidFit; _.ExactCorrection; _.FAILED; _.FAULT;
    _.FIELD_OUT_OF_RANGE; _.FIELD_RANGE_NT; _.FIRMWARE_VERSION; _.FIRST; _.FLOOR_RATIO; _.FLUSH_EVERY;
    _.FORMAT_VERSION; _.FRAC; _.FRACTION_BITS; _.FRAMES; _.FRAME_BYTES; _.FULL; _.FitError; _.GAINS; _.GAIN_MODELS;
    _.GP15; _.Gates; _.Guard; _.H; _.HEAD; _.HEADER; _.HEALTHY_MS; _.HIST; _.HIST_INTS; _.Handler; _.Health; _.IN;
    _.INDEX; _.INTERNAL_ERROR; _.IO_ERROR; _.IRQ_FALLING; _.KEEP_CAL; _.KEPT_PREVIOUS; _.KINDS; _.Keys; _.LASTBAD;
    _.LEFT; _.LINE_TOO_LONG; _.LOG_BYTES; _.LONG; _.Led; _.MAGIC; _.MARK; _.MAX_BYTES; _.MAX_ERROR_SHARE;
    _.MAX_GAIN_STEP; _.MAX_ITER; _.MAX_LINE; _.MAX_MISFIT; _.MAX_PREDICTED_NT; _.MAX_WINDOW; _.MIN_BATCHES;
    _.MIN_OBSERVABILITY; _.MIN_SAMPLES; _.MIN_SPAN_C; _.MIN_TURN; _.MISO; _.MISSED; _.MODELS; _.MODULES; _.MOSI;
    _.MSB; _.NAME; _.NATIVE; _.NODES; _.NON_FINITE; _.NOT_BETTER; _.NOT_CALIBRATING; _.NOT_ELLIPSOID;
    _.NO_CALIBRATION; _.NO_COVERAGE; _.NO_MEMORY; _.OFFSET_LIMIT; _.ORDER; _.OUT; _.OVERFLOW; _.Output; _.PAIR;
    _.POLLIN; _.POOR_OBSERVABILITY; _.PREDICTED_ERROR_TOO_HIGH; _.PRIOR_OFFSET_NT; _.PRIOR_SHAPE;
    _.PROTOCOL_VERSION; _.PROVISIONAL_ITER; _.PULL_UP; _.Pin; _.Prior; _.Problem; _.Protocol; _.ProtocolError;
    _.Pull; _.Push; _.QUICK; _.QUICK_GAIN; _.QUICK_OFFSET_NT; _.RATES; _.RAW_LINE; _.RECORD; _.REG_BAUD;
    _.REPROBE_MAX_MS; _.REPROBE_MS; _.RESERVE_BYTES; _.RESHAPED; _.RESPONSE_NOT_FIRST_ORDER; _.RMS_TOO_HIGH;
    _.RP2040; _.Recorder; _.ResidualBatches; _.RotatingLog; _.SAFE; _.SAFE_AFTER; _.SAFE_AFTER_ERRORS;
    _.SCALE_BITS; _.SCHEMA; _.SERIAL_CHUNK; _.SHAPE_SIGMA; _.SHORT; _.SLOTS; _.SLOW_DOWN; _.SOLVE; _.SOURCES;
    _.SPI; _.STEP; _.SUMS_PATH; _.SURVEY; _.SYMMETRY_TOL; _.Sample; _.Screen; _.Session; _.State; _.StateMachine;
    _.Survey; _.TABLE; _.TAIL; _.TAN_BITS; _.TAU_LIMIT_S; _.TEMPCO_GAIN_LIMIT; _.TEMPCO_METHODS;
    _.TEMPCO_OFFSET_LIMIT; _.TEMP_RANGE_C; _.TOO_FAST; _.TOO_FEW_SAMPLES; _.TYPICAL; _.TauSums; _.Timer;
    _.UNCALIBRATED; _.UNIT; _.UNIT_BITS; _.UNKNOWN_COMMAND; _.UNKNOWN_KEY; _.UP; _.UnicodeError; _.VERSION; _.WDT;
    _.WIDTH; _.WORDS; _.WORSE_THAN_CURRENT; _.W_C; _.W_EXP; _.Z_WHITE; _._ALL; _._BITS; _._C; _._CHAINS;
    _._COEF_BITS; _._COUNT; _._DEG; _._DIAG_NUMBERS; _._DRAIN; _._EINVAL; _._EIO; _._ENABLE; _._ENOENT;
    _._ERROR_EVENT_MS; _._EXACT; _._EXTRAPOLATE_C; _._FEATS; _._FLUSH; _._GAIN_CODES; _._GAP_MS_MAX; _._GATE_BITS;
    _._GRID; _._G_SHIFT; _._GainsAndOffsets; _._HAS_F; _._HOUSE_MS; _._HUGE; _._ICO; _._IDLE_MS; _._IDX1; _._IDX2;
    _._IDX2M; _._IDX3; _._IDX4; _._INTS; _._ITER; _._KERNELS_FREE; _._LEFT; _._LIMIT; _._LINE_BYTES; _._LOG;
    _._LOW; _._MAX_RHO; _._MAX_SHIFT; _._MAX_STRIDE; _._MEANS; _._META_NUMBERS; _._META_TEXT; _._MIN_PAIRS;
    _._MIN_PROVISIONAL; _._MIN_SAMPLES; _._NAMES; _._NATIVE_LIMITS; _._NORM; _._NO_MEMORY; _._NUMBERS_AT;
    _._NativeDrain; _._NativeHandler; _._NativePush; _._NativeSample; _._ONE; _._PACKS; _._PHI;
    _._PROVISIONAL_ITER; _._PYTHON; _._QUEUE; _._RANGE_MARGIN_C; _._REACH; _._REPL_FEED_MS; _._REPL_WATCHDOG_MS;
    _._RES_US; _._RUN; _._SAMPLE; _._SAMPLE_CAL; _._SPARE; _._SQUARES; _._STRICT; _._TABLE; _._TABLES;
    _._TEMPCO_KEYS; _._TEMP_STEP_C; _._TEXT_MAX; _._TICKS_HALF; _._TICKS_PERIOD; _._TIMER; _._TO_FLOAT; _._TWO53;
    _._UNLOAD; _._WATCHDOG_CTRL; _._WATCHDOG_REASON; _.__file__; _.__import__; _.__init__; _._across; _._add;
    _._add_packed; _._add_prior; _._add_slow; _._after; _._append; _._axes; _._axis_chains; _._b_frac; _._b_int;
    _._backoff; _._bad; _._batch_time; _._between; _._bias; _._bias_spread; _._bias_sq; _._bits; _._blocks;
    _._board; _._bounds; _._bridge; _._bridged; _._buf; _._button; _._button_closed; _._c; _._cause; _._chain;
    _._chance_point; _._change; _._changed; _._check; _._check_fields; _._cho_solve; _._cholesky; _._clipped;
    _._clk1; _._close; _._closed; _._cmd; _._command; _._comp_temp; _._compensate; _._conclude; _._correct;
    _._count; _._counts; _._cs; _._cubic; _._cuts; _._d; _._data; _._delag_on; _._delagged; _._diff; _._dk;
    _._down_at; _._dr; _._drain; _._drdy; _._drdy_counter; _._drifted; _._dropped; _._due; _._e; _._eigh3; _._end;
    _._error_event_ms; _._exact; _._exists; _._f; _._f0; _._f1; _._f_unit; _._fail; _._fail_fast; _._fast;
    _._fast_mark; _._feed_from_timer; _._feeder; _._fill; _._final; _._first; _._fits; _._flat; _._frame;
    _._frame_means; _._frames; _._g; _._gap; _._gap_cb; _._gc; _._h; _._handler; _._healthy; _._hi_q;
    _._hi_settled_q; _._hole; _._holes; _._house_idles; _._i; _._idle; _._in_row; _._isqrt; _._isr; _._j;
    _._joined; _._k; _._keys; _._known_key; _._lagfit; _._last; _._last_code; _._least; _._led; _._length;
    _._level; _._lim; _._line; _._lo_q; _._lo_settled_q; _._long_sent; _._machine; _._magnitude; _._make_counter;
    _._marks; _._max_ms; _._merge; _._monomials; _._n; _._name; _._native; _._native_add; _._native_correct;
    _._native_line; _._native_magnitude; _._native_survey; _._nearest; _._next; _._noise_gradient;
    _._normal_matrix; _._now_ns; _._nq; _._number; _._on_gap; _._one; _._open; _._open_next; _._out; _._output;
    _._outputs; _._overlong; _._parabola_min; _._pass_ms; _._pattern; _._pin; _._pins; _._poll; _._pressed;
    _._prog; _._q; _._queue; _._quiet_from; _._quiet_ms; _._rate; _._raw; _._rbuf; _._rd; _._read; _._read_bytes;
    _._read_waiting; _._readinto; _._recent; _._remove; _._replaced; _._reprobe_at; _._reset; _._resident;
    _._residuals; _._response_left; _._ring; _._rms; _._room; _._round_div; _._rp2040; _._rreg; _._s; _._s1; _._s2;
    _._sample_cb; _._scalar; _._scaled; _._seen; _._seen_mark; _._serve; _._service; _._set; _._settle;
    _._setup_pipeline; _._shape; _._shift; _._shifted; _._short; _._sigma; _._since_flush; _._sm; _._solve;
    _._solve_ms; _._solve_spd; _._span; _._span_check; _._sphere_gradients; _._spi_id; _._spike; _._sqrt_third;
    _._st; _._stands_out; _._start; _._start_counter; _._store; _._sub; _._sums_at; _._sums_path; _._survey; _._sx;
    _._sy; _._sym_eigenvalues; _._sync; _._sz; _._t; _._take; _._take_words; _._taus; _._taylor; _._temperature;
    _._temperature_warning; _._tick; _._unflushed; _._unload; _._unpack; _._until; _._use_exact; _._v;
    _._variance_sum; _._vector; _._view; _._vref_bit; _._w; _._want_f; _._wdt; _._why; _._widen; _._with_tempco;
    _._words; _._worse_than_current; _._wreg; _._write; _._zeroed; _._zeros; _.a; _.a_frame; _.a_int; _.a_values;
    _.a_vectors; _.abort; _.above; _.acc; _.acceptance; _.account_gap; _.acos; _.acq; _.acquisition; _.active;
    _.adc; _.adc_delagged; _.adc_faults; _.adc_probe; _.adc_silent; _.add; _.add_exp; _.add_prior;
    _.add_temperature; _.add_to; _.added; _.ads1292; _.age; _.all_finite; _.alloc_emergency_exception_buf;
    _.allowance; _.am; _.app; _.apply; _.apply_config; _.array; _.asm_pio; _.at; _.at_temperature; _.attach;
    _.attach_drdy; _.auto; _.available; _.axis; _.b; _.b_lines; _.back; _.bad_json; _.bad_scale; _.bad_value;
    _.badsync; _.base; _.basis; _.batch_length; _.batch_means; _.batches; _.baudrate; _.begin; _.below; _.best;
    _.between; _.bias; _.bias_spread; _.bin; _.binascii; _.bit_length; _.bits; _.blk; _.block; _.blocks; _.board;
    _.body; _.bool_auto; _.boot; _.boot_ms; _.bootguard; _.bp; _.break_chain; _.bridge; _.buf; _.buffer; _.busio;
    _.busy; _.button; _.button_edge; _.button_edges; _.by; _.c; _.cal; _.cal_kind; _.cal_now; _.cal_problem;
    _.cal_source; _.cal_temp_warn; _.calibrated; _.calibration; _.calibration_flow; _.callback; _.cals; _.can_join;
    _.cancel; _.cancel_cal; _.cancelled; _.cap; _.cell; _.cell_cap; _.cells; _.cells_per_edge; _.celsius; _.centre;
    _.centred; _.cfg; _.cfgmod; _.chains; _.changed; _.check; _.check_calibration; _.check_exact; _.check_response;
    _.check_tempco; _.chip; _.cho_solve; _.cholesky; _.clear_cal; _.cleared; _.cleared_at; _.clip; _.clip_axis;
    _.clipped; _.cls; _.cmd; _.code; _.codes; _.coefficients; _.collect; _.collecting; _.command; _.commands;
    _.config; _.config_problems; _.configure; _.configured_tau_s; _.console; _.context; _.correct; _.corrected;
    _.correlation_time; _.cos; _.count_drdy; _.counter; _.counts; _.cov; _.coverage; _.cpython; _.crash; _.crashed;
    _.crc; _.crc32; _.cross_check; _.cur; _.d; _.d1; _.d2; _.data; _.deadline_ms; _.debounce_ms; _.decim; _.decode;
    _.defaults; _.degrees; _.deinit; _.delag; _.delag_adc; _.delag_share; _.delag_us; _.delagc; _.delattr; _.den;
    _.det3; _.diagnostics; _.diff; _.digitalio; _.directions; _.dirs; _.discarded; _.dist_limit;
    _.disturbance_limit; _.divisor; _.dof; _.done; _.drdy; _.drdy_bus; _.drop_calibration; _.drop_modules;
    _.due_ms; _.dumps; _.dx; _.dy; _.dz; _.e; _.e1; _.e2; _.edge; _.eigh3; _.elapsed_s; _.enable; _.encode;
    _.enumerate; _.error; _.errors; _.estimate; _.estimated; _.ev; _.event; _.events; _.ex; _.exact; _.exact_blk;
    _.exact_ints; _.exact_pairs; _.exact_w; _.exact_words; _.exp; _.expm1; _.exponent; _.ey; _.ez; _.f; _.f_int;
    _.f_sigma; _.f_target; _.failed; _.fault; _.fault_code; _.fault_seen; _.faults; _.feed; _.field; _.field_nt;
    _.field_tol; _.fields; _.file_bytes; _.file_path; _.files; _.fill; _.final; _.finish; _.finish_cal; _.finished;
    _.firmware; _.firmware_names; _.firstbit; _.fit; _.fit_tempco; _.fits; _.fitsums; _.fitted; _.fixedpoint;
    _.flash; _.flashlog; _.flat; _.float; _.float_kernels; _.float_pair; _.floor; _.flow; _.flowing; _.flush;
    _.fmt; _.force; _.fraction; _.frame_floats; _.frame_means; _.frames; _.free_bytes; _.frexp; _.from_dict;
    _.from_sums; _.full; _.fw; _.g; _.g_lines; _.ga; _.gain; _.gain_code; _.gain_per_c; _.gain_ratio; _.gain_x;
    _.gain_y; _.gain_z; _.gains; _.gains_lr; _.gap; _.gaps; _.gate_dps; _.gates; _.gatesc; _.gc; _.get_cal;
    _.get_coverage; _.given; _.gradient; _.gradient_only; _.grads; _.groups; _.guard; _.h; _.hal;
    _.hal_circuitpython; _.hal_micropython; _.hand_back; _.handle; _.handler; _.hard; _.health; _.healthy; _.heard;
    _.held; _.held_ms; _.help; _.help_; _.hi; _.hist; _.hist_e; _.hist_i; _.hist_n; _.hold; _.honest;
    _.honest_error; _.huge; _.hundredths; _.hz; _.i; _.idle; _.ids; _.impl; _.implementation; _.in_base;
    _.in_basis; _.in_end; _.in_force; _.in_waiting; _.independent; _.indices; _.inf; _.info; _.init;
    _.initial_guesses; _.install; _.intern_names; _.interrupt; _.ints; _.io_error; _.ipoll; _.irq; _.isfinite;
    _.isqrt; _.isr; _.iterate; _.iteration; _.iterations; _.jac; _.jmp; _.json; _.json_number; _.k; _.k_nom;
    _.kbd_intr; _.keep; _.keep_cal; _.keep_watchdog_fed; _.kept; _.keypad; _.kind; _.kr; _.l; _.label; _.lag;
    _.lag_dps; _.lag_tol_nt; _.lagfit; _.lagrange_sums; _.lam; _.last_block; _.last_cal; _.last_coverage;
    _.last_direction; _.last_error; _.last_progress; _.last_result; _.last_solve; _.ldexp; _.leave; _.led; _.ledp;
    _.lim; _.limit; _.linalg; _.linalg_native; _.linalg_path; _.linalgc; _.line; _.lines; _.lo; _.load; _.loads;
    _.log; _.log1p; _.log_files; _.log_full; _.log_ratio; _.long_ms; _.loop_error; _.low; _.low_sums; _.lsb_volts;
    _.m; _.machine; _.magnitude; _.main_loop; _.make_prior; _.mark; _.marks; _.math; _.matrix; _.matvec; _.max;
    _.max_cal_s; _.max_error; _.max_iter; _.max_rms_nt; _.mean; _.mean_centre; _.means; _.mem32; _.mem_free;
    _.memoryview; _.merge; _.message; _.meta; _.method; _.min; _.min_count; _.min_observability; _.min_samples;
    _.mine; _.minimise; _.miso; _.missed; _.missing; _.mode; _.model; _.models; _.modules; _.moments;
    _.monotonic_ns; _.mosi; _.most; _.mov; _.mp; _.ms; _.msg; _.multiplier; _.n; _.n_cells; _.name; _.nan;
    _.native; _.native_numbers; _.nd; _.near; _.new; _.next_check_ms; _.nf; _.no_better_than; _.no_memory; _.nodes;
    _.noise_gradient; _.non_finite; _.normal_equations; _.normal_matrix; _.not_better; _.not_first_order; _.now;
    _.now_ms; _.num; _.numbers; _.obj; _.observability; _.off; _.offset; _.offset_nt; _.offset_per_c;
    _.offset_step; _.ok; _.old; _.on; _.on_cleared; _.on_gap; _.on_hole; _.on_joined; _.on_sample; _.op;
    _.opt_float; _.os; _.osr; _.other; _.out_end; _.outlier_nt; _.output; _.overflow; _.p; _.pack_into;
    _.parse_value; _.parts3; _.passed; _.path; _.pattern; _.pb; _.per_block; _.period; _.period_ms; _.phase; _.pin;
    _.pin_button; _.pin_cs0; _.pin_cs1; _.pin_drdy; _.pin_led; _.pin_miso; _.pin_mosi; _.pin_reset; _.pin_sck;
    _.pin_start; _.pio; _.platform; _.plausibility_problem; _.polarity; _.poll; _.polled; _.polls_drdy; _.pr;
    _.pred_nt; _.predicted; _.predicted_error; _.press; _.pressed; _.pressed_at; _.prior; _.prior_error;
    _.prior_residuals; _.prior_sq; _.probe; _.problem; _.progress; _.property; _.proto; _.protocol; _.provisional;
    _.provisional_error; _.pts; _.pull; _.push; _.put; _.python; _.q; _.q_sigma; _.q_target; _.quadric; _.quantise;
    _.quick; _.quit; _.quit_requested; _.radians; _.radius; _.range_c; _.rate; _.rate_changed; _.rate_code; _.raw;
    _.rb; _.rbuf; _.read_chunk; _.reader; _.readonly; _.ready; _.reason; _.recent_pairs; _.recent_rms; _.recentre;
    _.recentred; _.reconfigure; _.recorder; _.recording; _.records; _.ref; _.refine; _.refuse_worse; _.reg;
    _.register; _.rej_cap; _.rej_dist; _.rej_rate; _.rejected; _.rel; _.remount; _.remove_from; _.removed;
    _.rename; _.repl; _.reply; _.report; _.reprobe; _.reprobe_ms; _.reserve; _.reset; _.reset_by_watchdog;
    _.reshaped; _.resident; _.residual_rho; _.residual_stats; _.residuals; _.resp; _.respond; _.response;
    _.response_tau_s; _.restart; _.result; _.rho; _.ring; _.ring_frames; _.rms; _.rms_at; _.root; _.rp2; _.rss;
    _.rt; _.run; _.runtime; _.rx; _.ry; _.rz; _.s; _.safe_mode; _.safe_reason; _.sample; _.sample_cal; _.sample_hz;
    _.samples; _.saturated; _.save; _.save_error; _.saved; _.scale; _.scale_x; _.scale_y; _.scale_z; _.scaled;
    _.scaled_input; _.scaled_words; _.sck; _.screen; _.screenc; _.search_solves; _.seek; _.seen; _.select;
    _.send_line; _.sensor_is_slow; _.sensor_tau_s; _.serial_bytes_available; _.serial_read; _.serial_write;
    _.service; _.session; _.session_modules; _.set_cal; _.set_decimation; _.set_fault; _.set_reset; _.set_spi_rate;
    _.set_start; _.set_stream; _.set_taus; _.setup; _.sh; _.shape; _.shape_lr; _.shape_sigma; _.shared; _.shift;
    _.shifted; _.sign; _.since; _.size; _.skip; _.sleep; _.sleep_ms; _.sleep_us; _.sleeps_with_irq; _.slow_down;
    _.solve; _.solve_problem; _.solve_spd; _.solve_state; _.solver; _.solves; _.source; _.sources; _.spacing;
    _.sphere_gradients; _.spi; _.spi_id; _.spi_readinto; _.spi_write; _.spi_write_readinto; _.spike_nt; _.spikes;
    _.sqrt; _.st; _.stale_error; _.stale_rms; _.start; _.start_cal; _.started; _.starts; _.stat; _.state; _.status;
    _.statvfs; _.stdin; _.stdout; _.steady_led; _.steps_us; _.storage; _.store; _.stream; _.streaming; _.struct;
    _.sums; _.sums_at; _.sums_path; _.supervisor; _.survey; _.survey_hz; _.surveylog; _.sweeps; _.switch_to_input;
    _.switch_to_output; _.sx; _.sy; _.sym; _.sym_function; _.sync; _.sys; _.system; _.systematic_floor; _.sz; _.t;
    _.t0; _.t0_c; _.t_sigma; _.t_target; _.tan; _.tau; _.tau_int; _.tau_s; _.tau_sums; _.tau_t; _.tau_us;
    _.taus_us; _.tausums; _.tc; _.temp; _.temp_c; _.temp_n; _.temp_sum; _.temp_warn; _.tempco; _.tempco_in_range;
    _.tempco_record; _.temperature_c; _.temps; _.text; _.texts; _.theirs; _.tick; _.ticks_diff; _.ticks_ms; _.time;
    _.timed_out; _.timeout; _.tm; _.tmp; _.to_dict; _.to_float; _.too_fast; _.top; _.tr; _.trigger; _.try_lock;
    _.ts; _.turn_sd; _.u; _.unfinished_boots; _.uninstall; _.unit; _.units; _.unpack_from; _.uptime_ms; _.us;
    _.usb_cdc; _.use; _.use_provisional; _.v; _.validate; _.value_when_pressed; _.variance_sum; _.vectors;
    _.verifying; _.version; _.vref; _.vref_4v; _.w; _.wait; _.watchdog; _.watchdog_feed; _.watchdog_ms;
    _.watchdog_reset; _.watchdog_start; _.wb; _.wbuf; _.weighted_lines; _.weights; _.what; _.where; _.white;
    _.white_pred; _.width; _.window; _.words; _.worse_than; _.wrap; _.wrap_target; _.write_readinto; _.write_value;
    _.ws; _.x; _.x_dec; _.xyz; _.y; _.ys; _.z; _.zero; _.zeros; _[' on ']; _[' or auto']; _['#crc32=']; _['%.3g'];
    _['%02x']; _['%d\n%s\n']; _['%s.%s']; _['%s.%s: %s']; _['%s: %s']; _['%s[%d]']; _[', ']; _['-huge']; _['-inf'];
    _['.']; _['...']; _['.bak']; _['.frozen']; _['.json']; _['.tmp']; _['0.1.0']; _['1e300']; _['; ']; _['<5q'];
    _['<Ii']; _['<genexpr>']; _['<lambda>']; _['<listcomp>']; _['GP%d']; _['ads1292.py']; _['app.py'];
    _['boot.py']; _['boot.txt']; _['button.py']; _['cancel-cal']; _['choice:']; _['clear-cal']; _['code.py'];
    _['config.py']; _['finish-cal']; _['gates.py']; _['get-cal']; _['hal.py']; _['health.py']; _['keep-cal'];
    _['lagfit.py']; _['led.py']; _['log%d.csv']; _['main.py']; _['matrix[%d]']; _['not text']; _['screen.py'];
    _['session.py']; _['set-cal']; _['shared.fit']; _['start-cal']; _['store.py']; _['survey.bin']; _['survey.py'];
    _['{']; _['|'];


for _n in (
    'acceptance.py', 'acquisition.py', 'bootguard.py', 'calibration_flow.py', 'commands.py', 'flashlog.py',
    'hal_circuitpython.py', 'hal_micropython.py', 'protocol.py', 'residual_stats.py', 'residuals.py',
    'session_modules.py', 'shared.__init__', 'shared.calibration', 'shared.codes', 'shared.coverage',
    'shared.delag', 'shared.errors', 'shared.fixedpoint', 'shared.honest', 'shared.iteration', 'shared.linalg',
    'shared.linalg_native', 'shared.moments', 'shared.predicted', 'shared.prior', 'shared.quadric', 'shared.quick',
    'shared.response', 'shared.result', 'shared.solver', 'shared.start', 'shared.tausums', 'shared.tempco',
    'shared/__init__.py', 'shared/calibration.py', 'shared/codes.py', 'shared/coverage.py', 'shared/delag.py',
    'shared/errors.py', 'shared/fit.py', 'shared/fixedpoint.py', 'shared/honest.py', 'shared/iteration.py',
    'shared/linalg.py', 'shared/linalg_native.py', 'shared/moments.py', 'shared/predicted.py', 'shared/prior.py',
    'shared/quadric.py', 'shared/quick.py', 'shared/response.py', 'shared/result.py', 'shared/solver.py',
    'shared/start.py', 'shared/tausums.py', 'shared/tempco.py', 'surveylog.py',
):
    getattr(_, _n, None)

MODULES = (
    'acceptance', 'acquisition', 'ads1292', 'app', 'bootguard', 'button', 'calibration_flow', 'commands', 'config',
    'flashlog', 'gates', 'hal', 'hal_circuitpython', 'hal_micropython', 'health', 'lagfit', 'led', 'protocol',
    'residual_stats', 'residuals', 'screen', 'session', 'session_modules', 'shared/__init__', 'shared/calibration',
    'shared/codes', 'shared/coverage', 'shared/delag', 'shared/errors', 'shared/fit', 'shared/fixedpoint',
    'shared/honest', 'shared/iteration', 'shared/linalg', 'shared/linalg_native', 'shared/moments',
    'shared/predicted', 'shared/prior', 'shared/quadric', 'shared/quick', 'shared/response', 'shared/result',
    'shared/solver', 'shared/start', 'shared/tausums', 'shared/tempco', 'store', 'survey', 'surveylog',
)
